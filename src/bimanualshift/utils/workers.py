"""Run independent jobs in this process or in ``spawn`` worker processes, with a progress bar."""

from __future__ import annotations

import multiprocessing as mp
import time
from collections.abc import Callable, Iterable
from typing import TypeVar

from tqdm import tqdm

J = TypeVar("J")
R = TypeVar("R")


def run_jobs(fn: Callable[[J], R], jobs: Iterable[J], workers: int = 1, desc: str = "jobs", chunksize: int = 2,
             on_result: Callable[[R], None] | None = None, deadline: float | None = None) -> list[R]:
    """Results of ``fn`` over ``jobs`` in completion order (``fn`` must be importable: workers are spawned).
    ``on_result`` sees each result as it arrives (e.g. to append it to a log a killed run resumes from); after
    ``deadline`` (a ``time.time()``) no further result is waited for and the jobs still running are dropped."""
    jobs = list(jobs)
    results: list[R] = []
    with tqdm(total=len(jobs), desc=desc, unit="ep") as bar:
        if workers <= 1:
            for job in jobs:
                if deadline is not None and time.time() > deadline:
                    break
                results.append(fn(job))
                if on_result is not None:
                    on_result(results[-1])
                bar.update()
        else:
            with mp.get_context("spawn").Pool(workers) as pool:
                for result in pool.imap_unordered(fn, jobs, chunksize=chunksize):
                    if deadline is not None and time.time() > deadline:
                        break  # leaving the pool's context terminates the workers
                    results.append(result)
                    if on_result is not None:
                        on_result(result)
                    bar.update()
    return results
