"""The protocol every bimanual policy fills: the rollout loop, the benchmark and the server speak only to it."""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    import numpy as np


class Policy(Protocol):
    name: str

    def reset(self) -> None: ...

    def act(self, obs: object) -> np.ndarray:
        """One keyframe observation (``data.frames.KeyframeObservation``) -> (arms, action width) world rows."""
        ...
