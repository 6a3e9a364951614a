"""One episode, one outcome: every policy forward pass runs its ops on one intra-op thread.

torch splits a matrix product's reduction across its intra-op threads, so the same forward pass on 1 and on 2
threads differs in the last bits (about 1e-5 in a PerAct-style heat-map). An arg-max that flips or an action a
hair away sends the simulator elsewhere, and a seed's outcome then depends on the process that ran it: the main
process of ``eval`` (2 threads), a benchmark worker (1), a server (whatever the host gives it).

So a policy computes every op on one thread, whatever the process's own count (``policy_threads``). The process's
other cores are not lost: the arms' prior passes are independent, and ``map_arms`` runs them side by side, one
per core, each still on one thread, which gives the same bits as running them in turn.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import TypeVar

T = TypeVar("T")
R = TypeVar("R")

# Intra-op threads of every policy forward pass. The committed studies ran in benchmark workers on one thread.
POLICY_THREADS = 1

_state = threading.local()  # per calling thread: nesting depth and the thread count to restore
_pools: dict[int, ThreadPoolExecutor] = {}
_pools_lock = threading.Lock()


@contextmanager
def policy_threads() -> Iterator[None]:
    """Run the block's torch ops on ``POLICY_THREADS`` intra-op threads, then restore the caller's count. Nested
    blocks keep the outermost caller's count as the cores ``map_arms`` may use."""
    import torch

    depth = getattr(_state, "depth", 0)
    if depth == 0:
        _state.cores = torch.get_num_threads()
        torch.set_num_threads(POLICY_THREADS)
    _state.depth = depth + 1
    try:
        yield
    finally:
        _state.depth = depth
        if depth == 0:
            torch.set_num_threads(_state.cores)


def spare_cores() -> int:
    """The threads the calling process gave torch before ``policy_threads`` pinned them: the cores arms may share."""
    import torch

    return int(getattr(_state, "cores", 1)) if getattr(_state, "depth", 0) else torch.get_num_threads()


def _pool(workers: int) -> ThreadPoolExecutor:
    with _pools_lock:
        if workers not in _pools:
            _pools[workers] = ThreadPoolExecutor(workers, thread_name_prefix="arm")
        return _pools[workers]


def map_arms(fn: Callable[[T], R], items: Sequence[T], concurrent: bool = True) -> list[R]:
    """``[fn(x) for x in items]``, the items side by side on the caller's spare cores when ``concurrent`` (``fn``
    must not change shared state: a frozen prior's ``predict``). Each call runs on ``POLICY_THREADS`` threads in
    the caller's grad mode, so the results are the bits a sequential loop gives."""
    import torch

    workers = min(spare_cores(), len(items))
    if not concurrent or workers < 2:
        return [fn(x) for x in items]
    grad = torch.is_grad_enabled()

    def one(x: T) -> R:
        torch.set_num_threads(POLICY_THREADS)  # a pool thread keeps its own count (OpenMP's is per thread)
        with torch.set_grad_enabled(grad):
            return fn(x)

    return list(_pool(workers).map(one, items))
