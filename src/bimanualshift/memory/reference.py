"""From a retrieved execution to the Manager's temporal reference (Eq. 9-10 of the paper's retrieval).

An episode's memory key is built from its instruction embedding and the frozen prior's visual features of
the first observation (both arms, in arm order): E_vision(o_0) comes from the same frozen backbone the residual
already reads, so retrieval adds no encoder. At each keyframe, arm i of the current episode is given the stored
execution's action of arm i at the step its progress is aligned to (``ProgressAlignment``) -- as an offset from
the prior's own proposed position, the stored orientation and gripper state -- and the retrieval's similarity as
its confidence. Without a confident retrieval the reference is all zeros (confidence 0), which is also what the
"without retrieval" ablation sees.
"""

from __future__ import annotations

import numpy as np

from bimanualshift.geometry.frames import quat_toward
from bimanualshift.memory.bank import Retrieval, memory_key

REFERENCE_DIM = 3 + 4 + 1 + 1  # position offset from the prior's, quaternion, gripper, confidence


def episode_key(text: np.ndarray, first_features: list[np.ndarray]) -> np.ndarray:
    """The memory key of an episode: its instruction and the prior's features of each arm at keyframe 0."""
    return memory_key(text, np.concatenate([np.asarray(f, np.float32).ravel() for f in first_features]))


# A gripper in the other state than the stored step started from counts as this far away (metres), so a grasp
# step and the lift after it, which start from nearly the same place, are told apart.
GRIPPER_MISMATCH_M = 0.05
PROGRESS_WINDOW = 2  # an arm's aligned step advances by at most this many stored steps per keyframe
TIE_M = 1e-3  # stored steps whose starting poses are this close count as one place


class ProgressAlignment:
    """Which step of a retrieved execution each arm of the current episode is at, by progress rather than by the
    global keyframe index (an arm that waits, retries or is slower keeps its place in the stored execution).

    Per arm a pointer starts at step 0 and never goes back; at each keyframe it moves to whichever of the next
    ``PROGRESS_WINDOW`` + 1 stored steps (itself included) starts nearest to where the arm is now: the stored
    step's starting pose is the previous stored target (the episode's own first pose for step 0), its gripper
    state counting ``GRIPPER_MISMATCH_M``. Among equally near steps it moves one forward, so repeated stored targets
    (a hold) are replayed one per keyframe."""

    def __init__(self, trajectory: np.ndarray) -> None:
        self.trajectory = np.asarray(trajectory)  # (K, A, 8) arm-frame position, quaternion, gripper per step
        self.pointer: dict[int, int] = {}
        self.start: dict[int, tuple[np.ndarray, bool]] = {}

    def step_of(self, arm: int, position: np.ndarray, gripper_open: float) -> int:
        """The stored step arm ``arm`` is at, from its current arm-frame position and gripper opening."""
        position, is_open = np.asarray(position, np.float64), gripper_open > 0.5
        if arm not in self.pointer:
            self.pointer[arm], self.start[arm] = 0, (position, is_open)
            return 0
        p = self.pointer[arm]

        def cost(j: int) -> float:
            where, was_open = self.start[arm] if j == 0 else (self.trajectory[j - 1, arm, :3],
                                                              self.trajectory[j - 1, arm, 7] > 0.5)
            return float(np.linalg.norm(position - where)) + GRIPPER_MISMATCH_M * (was_open != is_open)

        costs = {j: cost(j) for j in range(p, min(p + PROGRESS_WINDOW, len(self.trajectory) - 1) + 1)}
        best = min(costs.values())
        tied = [j for j, c in costs.items() if c <= best + TIE_M]
        # among equally near steps (a repeated stored target: a hold), one step forward, never a jump
        self.pointer[arm] = next((j for j in tied if j > p), tied[0])
        return self.pointer[arm]


def reference_vector(retrieval: Retrieval | None, keyframe: int, arm: int, base_action: np.ndarray) -> np.ndarray:
    """(REFERENCE_DIM,) the retrieved action of ``arm`` at stored step ``keyframe`` (its aligned step), relative to
    the prior's action ``base_action`` (position, quaternion, gripper in the arm's frame); zeros without a
    retrieval."""
    out = np.zeros(REFERENCE_DIM, dtype=np.float32)
    if retrieval is None:
        return out
    stored = retrieval.reference_at(keyframe)[arm]
    out[:3] = stored[:3] - np.asarray(base_action[:3])
    # a rollout stores its executed quaternion with w >= 0, whose sign flips at random near the gripper-down pose;
    # the demos' are on the gripper-down side, so every reference is given on that side
    out[3:7] = quat_toward(stored[3:7])
    out[7] = stored[7]
    out[8] = retrieval.similarity
    return out
