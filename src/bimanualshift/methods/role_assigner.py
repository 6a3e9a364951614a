"""Which role each arm plays in an episode (``--roles true``): the arm that leads and the arm that follows.

In many bimanual tasks the scene decides which arm does which part (take tray out of oven: the arm on the tray's
side takes it, the other opens the door; a mirrored layout swaps them). A residual whose keyframe slots belong to
arm names then sees two different targets in one slot and learns their average. With roles, the slots belong to
(role, arm) pairs, and the roles are decided once per episode, at its first keyframe, from what each arm observes.

Labels come from the demos (``training/roles.py``): the arm that moves first leads. The assigner is a logistic
regression from an arm's first-keyframe observation (the goal's geometry and both arms' proprio in its frame, and
which arm it is) to "leads"; of the two arms the likelier leads. A task whose demos always let the same arm lead
(symmetric tasks: ties go to the first arm) needs no classifier: the roles are the arms' order, and the one-hot is
the per-arm one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from bimanualshift.methods.instruction_chooser import InstructionChooser, chooser_features

LEADS, FOLLOWS = "leads", "follows"  # the classifier's two classes (role 0 and role 1)


def role_features(goal: np.ndarray, proprio: np.ndarray, other_proprio: np.ndarray, arm_index: np.ndarray
                  ) -> np.ndarray:
    """(N, 2F + 1) what the assigner reads per arm: the instruction chooser's features, the same times the arm's
    sign (-1 first arm, +1 second) and the arm's index last: each arm gets its own linear rule, because one scene
    cue points opposite ways in the two arms' frames (the goal lies to one arm's right and the other's left)."""
    base = chooser_features(goal, proprio, other_proprio)
    index = np.asarray(arm_index, np.float64).reshape(-1, 1)
    return np.concatenate([base, base * (2 * index - 1), index], axis=1)


def fixed_by_arm(roles: np.ndarray, arm_index: np.ndarray) -> bool:
    """Whether every arm plays the same role in every demo (sweep to dustpan: the right arm always leads)."""
    return all(len(set(np.asarray(roles)[np.asarray(arm_index) == a].tolist())) <= 1 for a in set(arm_index.tolist()))


@dataclass
class RoleAssigner:
    """Decides the roles (0 leads, 1 follows) of an episode's arms; ``chooser`` None: role = the arm's index."""

    chooser: InstructionChooser | None = None
    accuracy: float | None = None  # on the demos it was fitted on (per arm), for the run's record

    def assign(self, features: np.ndarray) -> np.ndarray:
        """(A,) int: each arm's role from its first-keyframe ``role_features`` (A, F): exactly one arm leads."""
        features = np.atleast_2d(np.asarray(features, np.float64))
        arms = len(features)
        if self.chooser is None or arms == 1:
            return np.arange(arms)
        logits = self.lead_logits(features)
        roles = np.ones(arms, np.int64)
        roles[int(np.argmax(logits))] = 0
        return roles

    def lead_logits(self, features: np.ndarray) -> np.ndarray:
        """(A,) how much likelier each arm leads than follows (the logistic regression's margin)."""
        logits = self.chooser.logits(features)
        lead = self.chooser.instructions.index(LEADS)
        return logits[:, lead] - logits[:, 1 - lead]

    @classmethod
    def fit(cls, features: np.ndarray, roles: np.ndarray, arm_index: np.ndarray) -> RoleAssigner:
        """From (N, F) first-keyframe features of demo arms, their roles (N,) and arm indices (N,): no classifier
        when each arm plays one role in every demo (the roles then say no more than the arms' names; a trainer
        keeps the per-arm slots), else a fitted classifier."""
        roles, arm_index = np.asarray(roles), np.asarray(arm_index)
        if fixed_by_arm(roles, arm_index):
            return cls(None, 1.0)
        labels = [LEADS if r == 0 else FOLLOWS for r in roles]
        chooser = InstructionChooser.fit(features, labels)
        fitted = cls(chooser)
        fitted.accuracy = round(float(np.mean([p == r for p, r in zip(fitted.predict_rows(features), roles)])), 4)
        return fitted

    def predict_rows(self, features: np.ndarray) -> np.ndarray:
        """(N,) each row's role judged alone by the fitted classifier (1 = follows where the margin is negative)."""
        return (self.lead_logits(features) < 0).astype(np.int64)

    def to_dict(self) -> dict[str, Any]:
        return {"chooser": None if self.chooser is None else self.chooser.to_dict(), "accuracy": self.accuracy}

    @classmethod
    def from_dict(cls, d: dict[str, Any] | None) -> RoleAssigner:
        if not isinstance(d, dict) or "chooser" not in d:
            raise ValueError("the saved role assigner is damaged (no 'chooser' entry): retrain with --roles true")
        chooser = InstructionChooser.from_dict(d["chooser"]) if d["chooser"] is not None else None
        if chooser is not None and sorted(chooser.instructions) != sorted((LEADS, FOLLOWS)):
            raise ValueError(f"the saved role assigner's classes are {chooser.instructions}, not {LEADS!r} and "
                             f"{FOLLOWS!r}: retrain with --roles true")
        return cls(chooser, d.get("accuracy"))
