"""A prior type of your own, outside the package: the PerAct-style network with dropout on its proprioception.

``@register_prior`` gives it a type name; checkpoints record it in their config.json, so `pretrain --prior
peract_dropout`, `train --prior <its run>/best` and every worker process find it once this file is a plugin:

    bimanualshift --plugin examples/plugins/my_prior.py pretrain --prior peract_dropout --data data/unimanual
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from bimanualshift.priors.base import register_prior
from bimanualshift.priors.peract.configuration_peract import PerActConfig
from bimanualshift.priors.peract.modeling_peract import PerActPrior


@dataclass
class PerActDropoutConfig(PerActConfig):
    proprio_dropout: float = 0.1  # probability of zeroing a proprioception feature while training


@register_prior("peract_dropout")
class PerActDropoutPrior(PerActPrior):
    config_class = PerActDropoutConfig

    def forward(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor, keep_maps: bool = False
                ) -> dict[str, torch.Tensor]:
        if self.training:
            proprio = torch.nn.functional.dropout(proprio, self.config.proprio_dropout)
        return super().forward(voxels, proprio, text, keep_maps)
