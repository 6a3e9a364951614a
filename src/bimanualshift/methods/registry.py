"""Every method the benchmark compares, by name: how it is trained on a task's demos and how it is loaded.

Methods share the task, data and rollout code; a method only says what differs (diffusion_policy's split of
tasks and methods: N tasks + M methods cost N + M code). The ablations are the full method with one switch off.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bimanualshift.configs import RESIDUAL_STEPS
from bimanualshift.evaluation.rollout import Policy


@dataclass(frozen=True)
class TrainRequest:
    """What the benchmark hands every method: one task's demos and where to put the run."""

    task: str
    data: str  # train demos (one sub-folder per task)
    validation_data: str  # validation demos (checkpoint choice)
    demos: int
    prior: str  # the frozen single-arm prior (a folder or a shipped name)
    out: str  # the method's run directory for this task
    steps: int = 1500
    seed: int = 0
    overrides: dict[str, Any] = field(default_factory=dict)  # extra TrainConfig fields


@dataclass(frozen=True)
class MethodSpec:
    name: str
    description: str
    train: Callable[[TrainRequest], Path | None]  # the checkpoint to evaluate; None when nothing is trained
    load: Callable[[Path | None, TrainRequest], Policy]
    # Continual learning: the method can start from its own earlier run on another task (the request's
    # ``overrides["init_from"]`` names that run's folder).
    continual: bool = False
    steps: int | None = None  # its default training steps (None: the benchmark's default)


METHODS: dict[str, MethodSpec] = {}


def register_method(spec: MethodSpec) -> MethodSpec:
    if spec.name in METHODS:
        raise ValueError(f"method {spec.name!r} is already registered")
    METHODS[spec.name] = spec
    return spec


def get_method(name: str) -> MethodSpec:
    if name not in METHODS:
        raise ValueError(f"unknown method {name!r}; choose from {sorted(METHODS)}")
    return METHODS[name]


def _residual_method(name: str, description: str, **switches: Any) -> MethodSpec:
    """BimanualShift trained with ``switches`` (TrainConfig fields) on top of the request."""

    def train(request: TrainRequest) -> Path:
        from bimanualshift.training.residual import TrainConfig, train_residual

        cfg = TrainConfig(task=request.task, prior=request.prior, data=request.data,
                          validation_data=request.validation_data, out=request.out, demos=request.demos,
                          steps=request.steps, seed=request.seed, **{**switches, **request.overrides})
        best = Path(request.out) / "best"
        if (Path(request.out) / "summary.json").is_file() and (best / "config.json").is_file():
            return best  # trained by an earlier (interrupted) benchmark run
        return train_residual(cfg)

    def load(checkpoint: Path | None, request: TrainRequest) -> Policy:
        from bimanualshift.methods.bimanualshift import load_bimanualshift

        policy = load_bimanualshift(checkpoint)
        policy.name = name
        return policy

    return MethodSpec(name, description, train, load, continual=True, steps=RESIDUAL_STEPS)


def _frozen_prior_method(name: str, description: str, use_projection: bool) -> MethodSpec:
    def load(checkpoint: Path | None, request: TrainRequest) -> Policy:
        from bimanualshift.encoders.text import default_text_encoder
        from bimanualshift.methods.frozen_prior import FrozenPriorPerArm

        return FrozenPriorPerArm.from_pretrained(request.prior, default_text_encoder(), name=name,
                                                 use_projection=use_projection)

    return MethodSpec(name, description, lambda request: None, load)


register_method(_residual_method(
    "bimanualshift", "projection + residual skill modulation + retrieval (the full method)", retrieval=True))
register_method(_residual_method(
    "no_projection", "ablation: the prior sees the global scene", retrieval=True, use_projection=False))
register_method(_frozen_prior_method(
    "no_residual", "ablation: the frozen prior per arm through the projection, no residual", use_projection=True))
register_method(_residual_method(
    "no_retrieval", "ablation: no memory bank reference", retrieval=False))
register_method(_residual_method(
    "unstructured", "ablation: an MLP residual with no skill basis", retrieval=True, structured=False))
register_method(_frozen_prior_method(
    "frozen_prior_per_arm", "baseline: the frozen prior drives each arm on the global scene, nothing trained",
    use_projection=False))



def _backbone_method(name: str, description: str, trainer: str, policy: str, continual: bool = False) -> MethodSpec:
    """A baseline that trains or fine-tunes a voxel backbone; ``trainer`` / ``policy`` name functions in
    ``bimanualshift.methods.baselines.<module>`` as "module:function"."""

    def _resolve(ref: str) -> Callable[..., Any]:
        import importlib

        module, func = ref.split(":")
        return getattr(importlib.import_module(f"bimanualshift.methods.baselines.{module}"), func)

    def train(request: TrainRequest) -> Path:
        done = Path(request.out) / "done.json"
        if done.is_file():  # trained by an earlier (interrupted) benchmark run
            return Path(json.loads(done.read_text()))
        checkpoint = _resolve(trainer)(request, **request.overrides)
        from bimanualshift.utils.io import atomic_write_json

        atomic_write_json(Path(request.out) / "done.json", str(checkpoint))
        return checkpoint

    def load(checkpoint: Path | None, request: TrainRequest) -> Policy:
        from bimanualshift.encoders.text import default_text_encoder

        return _resolve(policy)(checkpoint, default_text_encoder())

    return MethodSpec(name, description, train, load, continual)


register_method(_backbone_method(
    "scratch_voxel", "baseline: a PerAct2-style voxel policy for both arms trained from scratch on the bimanual demos "
    "(global scene, no prior, no residual)", "scratch_voxel:train_scratch_voxel", "scratch_voxel:ScratchVoxelPolicy"))
register_method(_backbone_method(
    "peract_lf", "baseline: PerAct-LF, leader (right) and follower (left) networks fine-tuned from the single-arm "
    "prior on the bimanual demos; the follower conditions on the leader's action",
    "leader_follower_tuned:train_leader_follower", "leader_follower_tuned:LeaderFollowerPolicy", continual=True))
register_method(_backbone_method(
    "anybimanual", "baseline: AnyBimanual-style, the single-arm prior fine-tuned with learned soft voxel masks per arm "
    "and skill-weighted language", "anybimanual:train_anybimanual", "anybimanual:AnyBimanualPolicy"))
register_method(_backbone_method(
    "dp_lf", "baseline: DP-LF, the leader-follower pair fine-tuned from the shipped Diffusion Policy prior (dp_suite) "
    "on the bimanual demos", "leader_follower_tuned:train_dp_leader_follower",
    "leader_follower_tuned:DiffusionLeaderFollowerPolicy", continual=True))
register_method(_backbone_method(
    "scratch_dp", "baseline: a Diffusion Policy for both arms (point cloud of the global scene, the other arm's pose "
    "and the acting arm's one-hot as extra proprioception) trained from scratch on the bimanual demos only",
    "scratch_voxel:train_scratch_dp", "scratch_voxel:ScratchDiffusionPolicy"))
register_method(_backbone_method(
    "scratch_act", "baseline: ACT (a CVAE transformer predicting action chunks; point cloud of the global scene, the "
    "other arm's pose and the acting arm's one-hot as extra proprioception) trained from scratch on the bimanual demos",
    "scratch_voxel:train_scratch_act", "scratch_voxel:ScratchACTPolicy"))
