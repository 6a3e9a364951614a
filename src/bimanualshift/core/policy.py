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


class KeyframeLogging(Protocol):
    """What a policy may add to each keyframe's log (``rollout`` asks for it after every ``act``): per arm its
    frozen prior's action, its final action, whether it held, and the policy's own diagnostics such as the
    retrieval similarity. Plain JSON values."""

    def keyframe_log(self) -> dict: ...
