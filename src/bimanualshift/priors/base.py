"""The frozen unimanual prior interface and its registry.

A prior maps one arm's observation in its own base frame (voxels, proprioception, instruction embedding)
to that arm's next keyframe action (optionally a chunk of the next few), and exposes the visual features the
residual Manager consumes. Any single-arm policy can serve BimanualShift by subclassing ``UnimanualPrior``:

* ``predict(voxels, proprio, text) -> PriorOutput`` -- inference, no gradients;
* ``compute_loss(inputs, actions, generator) -> {"total": ..., ...}`` -- its own training objective on
  continuous arm-frame action targets (``position`` (B, H, 3), ``quat`` (B, H, 4), ``gripper_open`` and
  ``ignore_collisions`` (B, H)), so one pretraining loop and one augmentation serve every prior;
* ``local_features(voxels, proprio, text, points)`` -- its features at arm-frame points (``local_feature_dim``
  wide), and ``PriorOutput.logits`` -- its action distribution before decoding, where it has one;
* ``feature_dim``, ``action_horizon`` (H), ``reset()`` (between episodes), ``freeze()``,
  ``set_normalization(positions)`` (statistics kept as buffers, saved with the weights).

Checkpoints are ``model.safetensors`` + ``config.json``; the config's ``type`` picks the class, and a shipped
checkpoint can be loaded by its name (``UnimanualPrior.from_pretrained("peract_suite")``).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import numpy as np
import torch
from safetensors.torch import save_file
from torch import nn

from bimanualshift.configs import PRIOR_SIZES, prior_model_config
from bimanualshift.perception.arm_samples import padded_cloud
from bimanualshift.utils.config_files import CheckpointError, config_from_dict, load_checked_weights, read_json_file
from bimanualshift.utils.hub import is_hub_ref, resolve_local
from bimanualshift.utils.io import atomic_write_text, atomic_writer
from bimanualshift.utils.plugins import load_plugins


@dataclass
class PriorOutput:
    position: torch.Tensor  # (B, 3) arm-frame target position
    quat: torch.Tensor  # (B, 4) arm-frame target orientation, x y z w
    gripper_open: torch.Tensor  # (B,) probability
    ignore_collisions: torch.Tensor  # (B,) probability
    features: torch.Tensor  # (B, F) visual features for the residual Manager
    chunk: torch.Tensor | None = None  # (B, H, 8) the next H keyframe actions, for priors that predict chunks
    # The action distribution before decoding, for priors that have one (PerAct-style: ``translation`` (B, S^3)
    # heat-map logits over the arm-frame voxels, ``rotation`` (B, 3, bins), ``gripper`` and ``collision`` (B, 2)):
    # what a residual in action space re-weights. None for priors that sample their actions.
    logits: dict[str, torch.Tensor] | None = None
    # (B, 3) a coarse-to-fine prior's first-stage position (RVT-2-style), to report what its second stage adds
    coarse_position: torch.Tensor | None = None
    # (B, proposal_feature_dim) what the prior computed at and around its own proposed position: the residual
    # Manager's arm-specific visual input (Eq. 6). Filled by priors that have the maps at hand when predicting
    # (PerAct-style, RVT-style); ``UnimanualPrior.proposal_features`` fills it for the others.
    proposal_features: torch.Tensor | None = None

    def base_action(self) -> torch.Tensor:
        """(B, 8) position, quaternion and gripper: the prior's own action as the Manager sees it."""
        return torch.cat([self.position, self.quat, self.gripper_open[:, None]], dim=-1)


@dataclass
class PriorConfig:
    type: ClassVar[str] = "base"
    # The prior's input processing, saved with it: the keyframe index enters the proprioception (last value) as
    # index / max_keyframes, in training and at inference alike (``UnimanualPrior.arm_proprio``).
    max_keyframes: int = 25

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.type, **asdict(self)}


class UnimanualPrior(nn.Module):
    config_class: ClassVar[type[PriorConfig]]
    proprio_weight: ClassVar[str] = ""  # state-dict key of the proprioception's input layer (for widening)
    # every proprioception input layer, when there are several (the RVT prior's two stages); default: the one above
    extra_proprio_weights: ClassVar[tuple[str, ...]] = ()
    # What ``predict``'s first input is: "voxels" (B, 4, S, S, S) occupancy + rgb, or "points" (B, P, 6) the arm's
    # (masked) point cloud, arm-frame xyz and rgb, P = ``config.num_points`` (see ``observation_input``).
    observation: ClassVar[str] = "voxels"
    # Whether ``predict`` (and ``proposal_features``) may run for both arms at once on two threads: true where they
    # change no state of the module (a diffusion prior's scheduler keeps its timesteps, so it runs the arms in turn)
    concurrent_predict: ClassVar[bool] = False

    @property
    def cloud_points(self) -> int:
        """Points the observation builder must keep per arm (0: this prior reads voxels only)."""
        return int(getattr(self.config, "num_points", 0)) if self.observation == "points" else 0

    def observation_input(self, voxels: np.ndarray, points: np.ndarray | None) -> np.ndarray:
        """The array ``predict`` reads for one arm (no batch axis), from that arm's observation."""
        if self.observation == "voxels":
            return voxels
        if points is None:
            raise ValueError(f"{type(self).__name__} reads point clouds: build observations with "
                             f"ArmObservationBuilder(..., points={self.cloud_points})")
        return padded_cloud(points, self.cloud_points)

    def __init__(self, config: PriorConfig) -> None:
        super().__init__()
        self.config = config

    @property
    def feature_dim(self) -> int:
        raise NotImplementedError

    @property
    def action_horizon(self) -> int:
        """Keyframe actions per prediction (and per training target)."""
        return 1

    def predict(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor) -> PriorOutput:
        raise NotImplementedError

    @property
    def local_feature_dim(self) -> int:
        """Width of ``local_features``; 0 for a prior that has no spatial features."""
        return 0

    def local_features(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor,
                       points: torch.Tensor) -> torch.Tensor:
        """(B, local_feature_dim) the prior's features at arm-frame points (B, 3): what it computed about that
        place in the scene (e.g. where its own action or the goal is), for the residual's Manager."""
        raise NotImplementedError(f"{type(self).__name__} exposes no local features (local_feature_dim is 0)")

    @property
    def rotation_bin_degrees(self) -> float:
        """Width of the prior's rotation bins (0: it has no discrete rotation, so no action-space residual)."""
        return float(getattr(self.config, "rotation_bin_degrees", 0.0))

    def translation_scores(self, out: PriorOutput, points: torch.Tensor) -> torch.Tensor:
        """(B, M) the log-probability the prior's translation distribution (``out.logits``) gives arm-frame
        ``points`` (B, M, 3): the heat-map an action-space residual adds its logits to."""
        raise NotImplementedError(f"{type(self).__name__} exposes no translation distribution: an action-space "
                                  "residual needs a heat-map prior (PerAct-style or RVT-style)")

    @property
    def proposal_feature_dim(self) -> int:
        """Width of ``proposal_features``: by default the local features at the proposed point (0: none)."""
        return self.local_feature_dim

    @torch.no_grad()
    def proposal_features(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor,
                          out: PriorOutput) -> torch.Tensor:
        """(B, proposal_feature_dim) the prior's features at and around ``out``'s proposed position: those
        ``predict`` filled in, else ``local_features`` read at the proposal (one more pass)."""
        if out.proposal_features is not None:
            return out.proposal_features
        if not self.proposal_feature_dim:
            raise ValueError(f"{type(self).__name__} exposes no local features, so the Manager cannot read its "
                             "proposal's features (train the residual with --proposal-features false)")
        return self.local_features(voxels, proprio, text, out.position)

    def compute_loss(self, inputs: tuple[torch.Tensor, ...], actions: dict[str, torch.Tensor],
                     generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        raise NotImplementedError

    def set_normalization(self, positions: torch.Tensor) -> None:
        """Fit normalisation statistics to the training actions' positions (N, 3); a no-op by default."""

    def reset(self) -> None:
        """Forget any state kept across calls within an episode (none by default)."""

    def freeze(self) -> UnimanualPrior:
        """Frozen priors never learn and never leave eval mode (no dropout or batch-norm updates)."""
        self.eval()
        for p in self.parameters():
            p.requires_grad_(False)
        return self

    def train(self, mode: bool = True) -> UnimanualPrior:
        if mode and any(not p.requires_grad for p in self.parameters()):
            mode = False  # a frozen prior stays in eval mode even inside a module put in training mode
        return super().train(mode)

    def arm_proprio(self, own: np.ndarray, keyframe_index: int) -> np.ndarray:
        """The proprioception row this prior reads: the arm's own values, then the keyframe fraction."""
        return np.r_[own, keyframe_index / self.config.max_keyframes].astype(np.float32)

    def save_pretrained(self, directory: str | Path, extra: dict[str, Any] | None = None) -> Path:
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        tensors = {k: v.detach().contiguous() for k, v in self.state_dict().items()}
        with atomic_writer(directory / "model.safetensors") as tmp:
            save_file(tensors, str(tmp))
        atomic_write_text(directory / "config.json", json.dumps({**self.config.to_dict(), **(extra or {})}, indent=2))
        return directory

    @staticmethod
    def from_pretrained(directory: str | Path, overrides: dict[str, Any] | None = None) -> UnimanualPrior:
        """Load from a checkpoint directory, or by the name of a shipped checkpoint (see ``shipped_priors``).
        ``overrides`` change config fields that leave the weights' shapes alone (e.g. how many points a cloud
        prior reads, when pretraining continues); one that changes a tensor's shape is refused by name."""
        directory = resolve_prior_path(directory)
        cfg_path, weights = directory / "config.json", directory / "model.safetensors"
        for p in (cfg_path, weights):
            if not p.is_file():
                raise FileNotFoundError(f"prior checkpoint {directory} has no {p.name}; expected config.json and "
                                        "model.safetensors (train one with `bimanualshift pretrain`)")
        raw = {**read_json_file(cfg_path, "prior's config"), **(overrides or {})}
        kind = raw.get("type")
        if kind not in PRIORS:
            load_plugins()  # a user's prior type, registered by a plugin
        if kind not in PRIORS:
            raise CheckpointError(f"{cfg_path}: unknown prior type {kind!r}; known: {sorted(PRIORS)} (a prior of "
                                  "your own registers with @register_prior in a --plugin module)")
        cls = PRIORS[kind]
        model = cls(config_from_dict(cls.config_class, raw, cfg_path))
        load_checked_weights(model, weights, "copy both files from the same run")
        return model


# The shipped priors live in the repository's checkpoints/ folder, not in a wheel; BIMANUALSHIFT_CHECKPOINTS points an
# installed package at a clone's (or any folder of prior checkpoints).
SHIPPED_ENV = "BIMANUALSHIFT_CHECKPOINTS"
SHIPPED_DIR = Path(__file__).resolve().parents[3] / "checkpoints"


def shipped_dir() -> Path:
    return Path(os.environ[SHIPPED_ENV]) if os.environ.get(SHIPPED_ENV) else SHIPPED_DIR


def shipped_priors() -> list[str]:
    """Names of the prior checkpoints in the repository's ``checkpoints/`` folder (or $BIMANUALSHIFT_CHECKPOINTS)."""
    folder = shipped_dir()
    if not folder.is_dir():
        return []
    return sorted(p.name for p in folder.iterdir() if (p / "config.json").is_file())


# Versioned names of the checkpoints shipped before the single-arm suite was widened (their folders keep their
# first names, which the committed result files use): both spellings load the same weights.
VERSIONED_PRIORS = {"peract_suite_v1": "peract_suite", "dp_suite_v1": "dp_suite",
                    "peract_unimanual_v1": "peract_unimanual"}


def resolve_prior_path(name_or_path: str | Path) -> Path:
    """A directory as given, the cached snapshot of an ``hf://`` reference, or the shipped checkpoint of that name
    (or versioned name); a clear error for none of them."""
    if is_hub_ref(name_or_path):
        return resolve_local(name_or_path)
    path = Path(name_or_path)
    if path.is_dir():
        return path
    path = Path(VERSIONED_PRIORS.get(str(name_or_path), str(name_or_path)))
    folder = shipped_dir()
    if len(path.parts) == 1 and (folder / path).is_dir():
        return folder / path
    if not folder.is_dir():  # an installed package: the shipped priors stayed in the repository
        raise FileNotFoundError(f"no prior checkpoint directory {name_or_path!r}, and this install has no shipped "
                                f"priors ({folder} does not exist: they live in the repository's checkpoints/ folder, "
                                f"not in the package). Give a folder, an hf://ORG/NAME reference, or set {SHIPPED_ENV} "
                                "to a clone's checkpoints/")
    raise FileNotFoundError(f"no prior checkpoint directory {name_or_path!r} and no shipped prior of that name; "
                            f"shipped: {shipped_priors()} (a prior on the hub: hf://ORG/NAME)")


PRIORS: dict[str, type[UnimanualPrior]] = {}
P = TypeVar("P", bound=type[UnimanualPrior])


def register_prior(name: str) -> Callable[[P], P]:
    def wrap(cls: P) -> P:
        PRIORS[name] = cls
        cls.config_class.type = name
        return cls

    return wrap


PRIOR_ALIASES = {"dp": "diffusion"}


def prior_type(name: str) -> str:
    """A registered prior type from its name or alias (dp = diffusion); a clear error otherwise."""
    kind = PRIOR_ALIASES.get(name, name)
    if kind not in PRIORS:
        load_plugins()
    if kind not in PRIORS:
        raise ValueError(f"unknown prior {name!r}; available: {sorted(PRIORS)} (dp = diffusion)")
    return kind


def build_prior(name: str, size: str = "default", model: dict[str, Any] | None = None) -> UnimanualPrior:
    """A fresh network of prior type ``name``: a named size from ``bimanualshift.configs``, then ``model``'s
    config-field overrides on top."""
    kind = prior_type(name)
    cls = PRIORS[kind]
    # A prior type of the user's own (a plugin) has no named sizes: "default" is its config's defaults.
    named = {} if kind not in PRIOR_SIZES and size == "default" else prior_model_config(kind, size)
    values = {**named, **(model or {})}
    return cls(cls.config_class(**{k: tuple(v) if isinstance(v, list) else v for k, v in values.items()}))
