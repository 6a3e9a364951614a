"""Run independent jobs here, in ``spawn`` worker processes, or as Ray tasks on a cluster; with a progress bar.

Every pool in the project goes through ``run_jobs``. Its jobs are small specs (tuples, dataclasses of plain
values) and its results episode records of the same kind, so the Ray executor can carry both as JSON text:
Ray's own serialisation then moves only strings, inside the cluster's trusted network.
"""

from __future__ import annotations

import dataclasses
import importlib
import json
import multiprocessing as mp
import os
import time
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any, TypeVar

from tqdm import tqdm

J = TypeVar("J")
R = TypeVar("R")

EXECUTORS = ("local", "ray")
# Environment a Ray worker needs to render and load models the way this process does.
RAY_ENV_VARS = ("MUJOCO_GL", "PYOPENGL_PLATFORM", "HF_HUB_OFFLINE", "BIMANUALSHIFT_CACHE", "BIMANUALSHIFT_PLUGINS")


def run_jobs(fn: Callable[[J], R], jobs: Iterable[J], workers: int = 1, desc: str = "jobs", chunksize: int = 2,
             on_result: Callable[[R], None] | None = None, deadline: float | None = None,
             executor: str = "local") -> list[R]:
    """Results of ``fn`` over ``jobs`` in completion order (``fn`` must be importable: workers are spawned).
    ``on_result`` sees each result as it arrives (e.g. to append it to a log a killed run resumes from); after
    ``deadline`` (a ``time.time()``) no further result is waited for and the jobs still running are dropped.
    ``executor="ray"`` runs the jobs as Ray tasks (one CPU each) on the cluster ``RAY_ADDRESS`` names, or on a
    local one; ``workers`` then does not apply (the cluster's size does)."""
    if executor not in EXECUTORS:
        raise ValueError(f"unknown executor {executor!r}; choose one of {', '.join(EXECUTORS)}")
    jobs = list(jobs)
    results: list[R] = []

    def take(result: R) -> None:
        results.append(result)
        if on_result is not None:
            on_result(result)

    with tqdm(total=len(jobs), desc=desc, unit="ep") as bar:
        if executor == "ray":
            for result in _ray_results(fn, jobs, deadline):
                take(result)
                bar.update()
        elif workers <= 1:
            for job in jobs:
                if deadline is not None and time.time() > deadline:
                    break
                take(fn(job))
                bar.update()
        else:
            for result in _pool_results(fn, jobs, workers, chunksize, deadline):
                take(result)
                bar.update()
    return results


# ---- local processes ---------------------------------------------------------------------------------------
def _pool_results(fn: Callable[[J], R], jobs: list[J], workers: int, chunksize: int,
                  deadline: float | None) -> Iterable[R]:
    """Results of chunks of jobs run in ``spawn`` processes, in completion order. A worker that dies (killed,
    out of memory, a crash in native code) fails the run with ``BrokenProcessPool`` instead of leaving it
    waiting for a result that never comes, which is what ``multiprocessing.Pool`` does."""
    chunks = [jobs[i:i + max(1, chunksize)] for i in range(0, len(jobs), max(1, chunksize))]
    pool = ProcessPoolExecutor(min(workers, len(chunks)) or 1, mp_context=mp.get_context("spawn"))
    try:
        pending = {pool.submit(_run_chunk, fn, chunk) for chunk in chunks}
        while pending:
            timeout = None if deadline is None else max(0.0, deadline - time.time())
            done, pending = wait(pending, timeout=timeout, return_when=FIRST_COMPLETED)
            if not done:  # the deadline passed: queued chunks are dropped, running ones end with their episode
                return
            for future in done:
                yield from future.result()
    finally:
        pool.shutdown(wait=deadline is None or time.time() <= deadline, cancel_futures=True)


def _run_chunk(fn: Callable[[J], R], chunk: list[J]) -> list[R]:
    return [fn(job) for job in chunk]


# ---- Ray ---------------------------------------------------------------------------------------------------
def _ray_results(fn: Callable[[J], R], jobs: list[J], deadline: float | None) -> Iterable[R]:
    try:
        import ray
    except ImportError as err:
        raise ImportError("--executor ray needs Ray: pip install 'bimanualshift[cluster]'") from err
    if not ray.is_initialized():
        env = {k: os.environ[k] for k in RAY_ENV_VARS if k in os.environ}
        ray.init(address=os.environ.get("RAY_ADDRESS"), runtime_env={"env_vars": env} if env else None,
                 log_to_driver=False)
    task = ray.remote(num_cpus=1)(run_json_job)
    name = f"{fn.__module__}:{fn.__qualname__}"
    pending = [task.remote(name, json.dumps(to_json(job))) for job in jobs]
    while pending:
        timeout = None if deadline is None else max(0.0, deadline - time.time())
        done, pending = ray.wait(pending, num_returns=1, timeout=timeout)
        if not done:  # the deadline passed
            for ref in pending:
                ray.cancel(ref, force=True)
            return
        yield from_json(json.loads(ray.get(done[0])))


def run_json_job(fn_name: str, job: str) -> str:
    """Run ``module:function`` on a job given as JSON text; the result as JSON text (what a Ray task does)."""
    module, _, qualname = fn_name.partition(":")
    fn = getattr(importlib.import_module(module), qualname)
    return json.dumps(to_json(fn(from_json(json.loads(job)))))


def to_json(value: Any) -> Any:
    """Plain JSON for job specs and results: dataclasses and tuples are tagged so ``from_json`` rebuilds them."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        cls = type(value)
        return {"__dataclass__": f"{cls.__module__}:{cls.__qualname__}",
                "fields": {f.name: to_json(getattr(value, f.name)) for f in dataclasses.fields(value)}}
    if isinstance(value, tuple):
        return {"__tuple__": [to_json(v) for v in value]}
    if isinstance(value, list):
        return [to_json(v) for v in value]
    if isinstance(value, dict):
        if not all(isinstance(k, str) for k in value):
            raise TypeError(f"job and result dicts need string keys; got {list(value)[:5]}")
        return {k: to_json(v) for k, v in value.items()}
    if hasattr(value, "item") and callable(value.item):  # a numpy scalar
        return value.item()
    if value is None or isinstance(value, bool | int | float | str):
        return value
    raise TypeError(f"{type(value).__name__} cannot cross to a worker as JSON: jobs and results are plain values, "
                    "tuples, lists, dicts and dataclasses of them")


def from_json(value: Any) -> Any:
    if isinstance(value, list):
        return [from_json(v) for v in value]
    if isinstance(value, dict):
        if "__tuple__" in value:
            return tuple(from_json(v) for v in value["__tuple__"])
        if "__dataclass__" in value:
            module, _, qualname = value["__dataclass__"].partition(":")
            if not module.startswith("bimanualshift."):
                raise ValueError(f"refusing to build {value['__dataclass__']}: only bimanualshift's own job and "
                                 "record dataclasses cross to workers")
            cls = getattr(importlib.import_module(module), qualname)
            if not dataclasses.is_dataclass(cls):
                raise ValueError(f"{value['__dataclass__']} is not a dataclass")
            return cls(**{k: from_json(v) for k, v in value["fields"].items()})
        return {k: from_json(v) for k, v in value.items()}
    return value
