"""Trainers of the baselines that train or fine-tune a backbone, each with its own typed options.

A trainer takes the benchmark's ``TrainRequest`` and its method's config (``BackboneTrainConfig`` or
``LeaderFollowerTrainConfig``); the method registry pairs each trainer with its policy and default config.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

from bimanualshift.methods.baselines.anybimanual import SPEC as ANYBIMANUAL_SPEC
from bimanualshift.methods.baselines.from_scratch import ACT_SPEC, DP_SPEC
from bimanualshift.methods.baselines.from_scratch import SPEC as SCRATCH_VOXEL_SPEC
from bimanualshift.methods.baselines.leader_follower_tuned import PAIR_SPECS
from bimanualshift.methods.baselines.network_spec import VoxelNetworkSpec
from bimanualshift.methods.baselines.voxactb import SPEC as VOXACTB_SPEC
from bimanualshift.training.baseline_configs import BackboneTrainConfig, LeaderFollowerTrainConfig
from bimanualshift.training.finetune_backbone import train_voxel_network
from bimanualshift.training.request import TrainRequest
from bimanualshift.utils.io import atomic_write_json


def _train_one(spec: VoxelNetworkSpec, request: TrainRequest, cfg: BackboneTrainConfig) -> Path:
    return train_voxel_network(spec, request, Path(request.out), cfg.size, cfg.lr, cfg.batch_size,
                               cfg.checkpoint_every, cfg.optimizer)


def train_scratch_voxel(request: TrainRequest, cfg: BackboneTrainConfig) -> Path:
    return _train_one(SCRATCH_VOXEL_SPEC, request, cfg)


def train_scratch_dp(request: TrainRequest, cfg: BackboneTrainConfig) -> Path:
    """The Diffusion Policy network (point cloud of the global scene, action chunks) for both arms, from
    scratch."""
    return _train_one(DP_SPEC, request, cfg)


def train_scratch_act(request: TrainRequest, cfg: BackboneTrainConfig) -> Path:
    """ACT (CVAE transformer over action chunks) for both arms, from scratch."""
    return _train_one(ACT_SPEC, request, cfg)


def train_voxactb(request: TrainRequest, cfg: BackboneTrainConfig) -> Path:
    """The VoxAct-B-style network (a region of interest from the goal masks, acting / stabilising roles), from
    scratch."""
    return _train_one(VOXACTB_SPEC, request, cfg)


def train_anybimanual(request: TrainRequest, cfg: BackboneTrainConfig) -> Path:
    return _train_one(ANYBIMANUAL_SPEC, request, cfg)


def train_leader_follower(request: TrainRequest, cfg: LeaderFollowerTrainConfig) -> Path:
    """Fine-tune the pair from the single-arm prior, or (continual learning) from an earlier pair's run folder
    ``cfg.init_from``: each network then starts from its own earlier weights."""
    out = Path(request.out)
    if cfg.prior:
        request = replace(request, prior=cfg.prior)
    starts = {"leader": request, "follower": request}
    if cfg.init_from:
        path = Path(cfg.init_from) / "pair.json"
        if not path.is_file():
            raise FileNotFoundError(f"init_from={cfg.init_from!r}: no leader-follower pair there (pair.json missing)")
        earlier = json.loads(path.read_text())
        starts = {role: replace(request, prior=earlier[role]) for role in starts}
    if cfg.kind not in PAIR_SPECS:
        raise ValueError(f"no leader-follower pair of kind {cfg.kind!r}; choose from {sorted(PAIR_SPECS)}")
    specs = PAIR_SPECS[cfg.kind]
    leader = train_voxel_network(specs[0], starts["leader"], out / "leader", cfg.size, cfg.lr, cfg.batch_size,
                                 cfg.checkpoint_every, cfg.optimizer)
    follower = train_voxel_network(specs[1], starts["follower"], out / "follower", cfg.size, cfg.lr, cfg.batch_size,
                                   cfg.checkpoint_every, cfg.optimizer)
    atomic_write_json(out / "pair.json", {"type": {"peract": "peract_lf", "diffusion": "dp_lf"}.get(cfg.kind,
                                                                                                  f"{cfg.kind}_lf"),
                                          "leader": str(leader), "follower": str(follower)})
    return out
