"""One per-process cache for worker functions: a worker process builds each environment and each loaded policy
once, however many episodes it runs (every worker function in the project keeps its objects here)."""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Any

_CACHE: dict[Hashable, Any] = {}


def cached(key: Hashable, build: Callable[[], Any]) -> Any:
    if key not in _CACHE:
        _CACHE[key] = build()
    return _CACHE[key]
