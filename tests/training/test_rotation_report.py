"""The validation rotation report measures the turn left between the final orientation and the expert's."""

from __future__ import annotations

from dataclasses import dataclass

import torch

from bimanualshift.training.residual_data import ResidualData
from bimanualshift.training.residual_losses import rotation_report


@dataclass
class _Config:
    phase_dim: int = 0


class _FixedResidual:
    """A stand-in residual whose rotation output is fixed, without phase inputs."""

    config = _Config()

    def __init__(self, rotation: torch.Tensor) -> None:
        self.rotation = rotation

    def __call__(self, inputs: torch.Tensor) -> dict[str, torch.Tensor]:
        return {"translation": torch.zeros(len(inputs), 3), "rotation": self.rotation}


def test_the_error_is_the_turn_left_after_the_residual() -> None:
    target = torch.tensor([[0.0, 0.0, 1.2], [0.0, 0.0, 1.2], [0.3, 0.0, 0.0]])  # expert relative to the prior
    data = ResidualData(torch.zeros(3, 4), torch.zeros(3, 3), target)
    # turning 0.8 of a 1.2 rad turn leaves 0.4; a residual on another axis leaves the whole turn and more
    out = torch.tensor([[0.0, 0.0, 0.8], [0.0, 0.0, 0.8], [0.0, 0.0, 0.0]])
    report = rotation_report(_FixedResidual(out), data)
    assert report["prior_median_rad"] == 1.2
    assert report["prior_plus_residual_median_rad"] == 0.4
    assert rotation_report(_FixedResidual(target), data)["prior_plus_residual_median_rad"] == 0.0
