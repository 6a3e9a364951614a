"""The networks of the baselines that train or fine-tune a prior backbone: which arms' samples train a network,
what its proprioception holds beyond the arm's own, and where it starts from (random weights, or a single-arm
prior whose proprioception layer is widened with zero weights, so fine-tuning starts from exactly the prior's
behaviour). Policies read these at inference; ``training.finetune_backbone`` trains them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, replace

import numpy as np
import torch

from bimanualshift.data.episode import Episode
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.perception.arm_samples import ArmSamples
from bimanualshift.priors.base import UnimanualPrior, build_prior

OWN_PROPRIO = 8  # position, quaternion, gripper opening (the keyframe fraction comes last, after any extras)

# (samples of every arm, their episodes' arm frames) -> extra proprioception columns (N, E)
ExtraProprio = Callable[[ArmSamples, list[dict[str, ArmFrame]]], np.ndarray]


@dataclass(frozen=True)
class VoxelNetworkSpec:
    name: str
    arms: tuple[str, ...]  # whose samples train this network
    extra_dim: int  # proprioception values added after the arm's own 8
    extra_proprio: ExtraProprio | None = None
    extra_poses: tuple[int, ...] = ()  # where poses (position, quaternion) start among the extras
    init_from_prior: bool = False  # start from the request's prior, or from random weights
    kind: str = "peract"  # the network: peract or diffusion (a fine-tuned prior must be of this kind)
    build: Callable[[UnimanualPrior | None, int, str], UnimanualPrior] | None = None  # (prior, extra_dim, size)
    # each training episode rewritten before its samples are built (``voxactb``: the arms' frames re-anchored on
    # the region of interest); the policy applies the same rewrite to its observations
    episode_transform: Callable[[Episode], Episode] | None = None


def with_extra_proprio(samples: ArmSamples, extra: np.ndarray) -> ArmSamples:
    """Insert ``extra`` columns between the arm's own proprio and the keyframe fraction."""
    proprio = np.concatenate([samples.proprio[:, :OWN_PROPRIO], extra, samples.proprio[:, OWN_PROPRIO:]], axis=1)
    return replace(samples, proprio=proprio.astype(np.float32))


def select_arms(samples: ArmSamples, arms: tuple[str, ...]) -> ArmSamples:
    keep = np.flatnonzero([a in arms for a in samples.arm])
    return ArmSamples(**{k: ([v[i] for i in keep] if isinstance(v, list) else v if v is None else v[keep])
                         for k, v in vars(samples).items()})


def widen_from_prior(model: UnimanualPrior, prior: UnimanualPrior, extra_dim: int) -> None:
    """Copy the prior's weights; the wider proprioception layer gets zero weights for the extra columns. Modules
    ``model`` has beyond the prior's keep their own initialisation."""
    key = type(prior).proprio_weight
    if not key or key != type(model).proprio_weight:
        raise ValueError(f"cannot widen a {type(prior).__name__} into a {type(model).__name__}")
    state = {k: v.clone() for k, v in prior.state_dict().items()}
    for name in (key, *type(prior).extra_proprio_weights):
        old = state[name]  # (dim, OWN_PROPRIO [+ extras] + 1)
        width = model.state_dict()[name].shape[1]
        if old.shape[1] != width:  # a single-arm prior: widen; an earlier network of this kind already fits
            new = torch.zeros(old.shape[0], width)
            new[:, :OWN_PROPRIO] = old[:, :OWN_PROPRIO]
            new[:, -1] = old[:, -1]  # the keyframe fraction
            state[name] = new
    unexpected = model.load_state_dict(state, strict=False).unexpected_keys
    if unexpected:
        raise ValueError(f"the prior has weights this network lacks: {unexpected}")


def build_widened(prior: UnimanualPrior | None, extra_dim: int, size: str, kind: str = "peract") -> UnimanualPrior:
    """A network of ``kind`` reading ``extra_dim`` more proprio values: the prior's architecture and weights
    (widened), or a fresh network of the named size."""
    overrides = {"proprio_dim": OWN_PROPRIO + extra_dim}
    if prior is not None:
        overrides = {**asdict(prior.config), **overrides}
        prior_extra = prior.config.proprio_dim - OWN_PROPRIO
        if prior_extra not in (0, extra_dim):
            raise ValueError(f"cannot start a network reading {extra_dim} extra proprio values from one reading "
                             f"{prior_extra}")
    model = build_prior(prior.config.type if prior is not None else kind, size, overrides)
    if prior is not None:
        widen_from_prior(model, prior, extra_dim)
    return model
