"""Which instruction the frozen prior is asked, per arm, from what that arm observes (``--prior-instruction per_arm``).

A bimanual task's arms often do different single-arm skills (take tray out of oven: one opens the door, the other
takes the tray), and which arm does which depends on the scene (a mirrored layout swaps the roles), so no one
instruction per task or per arm name suits both. The chooser is a multinomial logistic regression from an arm's
goal geometry and both arms' proprio (what the Manager reads; they tell take tray's roles apart,
results/role_cues.json) to one of a few instructions, fitted on the training demos (training/prior_instruction.py).
Its weights are plain numbers saved as JSON with the run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from bimanualshift.perception.goal_geometry import UNION_GEOMETRY_DIM

OWN_PHRASING = ""  # the arm's prior reads the episode's own instruction (the paper)


def chooser_features(goal: np.ndarray, proprio: np.ndarray, other_proprio: np.ndarray) -> np.ndarray:
    """(N, F) what the chooser reads per arm: the goal's geometry in the arm's frame, the arm's proprio and the
    other arm's (arm frame; a keyframe fraction after the first 8 proprio entries is dropped). Of the goal it reads
    the union's box and extremities, the width it was fitted on before the object boxes existed."""
    goal, proprio, other = (np.atleast_2d(np.asarray(a, np.float64)) for a in (goal, proprio, other_proprio))
    return np.concatenate([goal[:, :UNION_GEOMETRY_DIM], proprio[:, :8], other[:, :8]], axis=1)


@dataclass
class InstructionChooser:
    instructions: list[str]  # one per class; OWN_PHRASING keeps the episode's instruction
    mean: np.ndarray  # (F,) feature standardisation
    scale: np.ndarray  # (F,)
    weight: np.ndarray  # (C, F)
    bias: np.ndarray  # (C,)

    def choose(self, features: np.ndarray) -> list[str]:
        """The instruction class for each row of ``features`` (N, F)."""
        return [self.instructions[i] for i in self.logits(features).argmax(axis=1)]

    def logits(self, features: np.ndarray) -> np.ndarray:
        """(N, C) the regression's class logits for each row of ``features`` (N, F)."""
        features = np.atleast_2d(np.asarray(features, np.float64))
        if features.shape[1] != self.mean.shape[0]:
            raise ValueError(f"the classifier reads {self.mean.shape[0]} features per arm, got "
                             f"{features.shape[1]}: it was fitted with another goal-geometry size; retrain the run")
        return ((features - self.mean) / self.scale) @ self.weight.T + self.bias

    @classmethod
    def fit(cls, features: np.ndarray, labels: list[str], l2: float = 1e-2, steps: int = 100) -> InstructionChooser:
        """A multinomial logistic regression (L2 weight ``l2``, L-BFGS from zero: deterministic) of ``labels`` on
        ``features`` (N, F)."""
        features = np.asarray(features, np.float64)
        if len(features) != len(labels) or not len(labels):
            raise ValueError(f"fit needs one label per feature row, got {len(features)} rows and {len(labels)} labels")
        classes = sorted(set(labels))
        mean, scale = features.mean(axis=0), features.std(axis=0)
        scale = np.where(scale > 1e-8, scale, 1.0)  # a constant feature (e.g. a goal part never seen) stays 0
        x = torch.as_tensor((features - mean) / scale)
        y = torch.as_tensor([classes.index(label) for label in labels])
        weight = torch.zeros(len(classes), x.shape[1], dtype=torch.float64, requires_grad=True)
        bias = torch.zeros(len(classes), dtype=torch.float64, requires_grad=True)
        optim = torch.optim.LBFGS([weight, bias], max_iter=steps, line_search_fn="strong_wolfe")

        def loss() -> torch.Tensor:
            optim.zero_grad()
            value = torch.nn.functional.cross_entropy(x @ weight.T + bias, y) + l2 * weight.pow(2).sum()
            value.backward()
            return value

        if len(classes) > 1:
            optim.step(loss)
        return cls(classes, mean, scale, weight.detach().numpy().copy(), bias.detach().numpy().copy())

    def to_dict(self) -> dict[str, Any]:
        return {"instructions": list(self.instructions), "mean": self.mean.tolist(), "scale": self.scale.tolist(),
                "weight": self.weight.tolist(), "bias": self.bias.tolist()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> InstructionChooser:
        missing = [k for k in ("instructions", "mean", "scale", "weight", "bias") if k not in d]
        if missing:
            raise ValueError(f"the saved instruction chooser lacks {', '.join(missing)}: the run's config.json or "
                             "prior_instruction.json is damaged; retrain with --prior-instruction per_arm")
        chooser = cls(list(d["instructions"]), *(np.asarray(d[k], np.float64) for k in ("mean", "scale", "weight",
                                                                                        "bias")))
        c, f = len(chooser.instructions), len(chooser.mean)
        if chooser.weight.shape != (c, f) or chooser.bias.shape != (c,) or chooser.scale.shape != (f,):
            raise ValueError(f"the saved instruction chooser's shapes disagree (weight {chooser.weight.shape} for "
                             f"{c} instructions and {f} features); retrain with --prior-instruction per_arm")
        return chooser
