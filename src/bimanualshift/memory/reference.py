"""From a retrieved execution to the Manager's temporal reference (Eq. 9-10 of the paper's retrieval).

An episode's memory key is built from its instruction embedding and the frozen prior's visual features of
the first observation (both arms, in arm order): E_vision(o_0) comes from the same frozen backbone the residual
already reads, so retrieval adds no encoder. At keyframe k, arm i of the current episode is given the stored
execution's action of arm i at keyframe k -- as an offset from the prior's own proposed position, the stored
orientation and gripper state -- and the retrieval's similarity as its confidence. Without a confident
retrieval the reference is all zeros (confidence 0), which is also what the "without retrieval" ablation sees.
"""

from __future__ import annotations

import numpy as np

from bimanualshift.memory.bank import Retrieval, memory_key

REFERENCE_DIM = 3 + 4 + 1 + 1  # position offset from the prior's, quaternion, gripper, confidence


def episode_key(text: np.ndarray, first_features: list[np.ndarray]) -> np.ndarray:
    """The memory key of an episode: its instruction and the prior's features of each arm at keyframe 0."""
    return memory_key(text, np.concatenate([np.asarray(f, np.float32).ravel() for f in first_features]))


def reference_vector(retrieval: Retrieval | None, keyframe: int, arm: int, base_action: np.ndarray) -> np.ndarray:
    """(REFERENCE_DIM,) the retrieved action of ``arm`` aligned to ``keyframe``, relative to the prior's action
    ``base_action`` (position, quaternion, gripper in the arm's frame); zeros without a retrieval."""
    out = np.zeros(REFERENCE_DIM, dtype=np.float32)
    if retrieval is None:
        return out
    stored = retrieval.reference_at(keyframe)[arm]
    out[:3] = stored[:3] - np.asarray(base_action[:3])
    out[3:8] = stored[3:8]
    out[8] = retrieval.similarity
    return out
