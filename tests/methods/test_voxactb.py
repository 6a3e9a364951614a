"""The VoxAct-B-style baseline: a region of interest from the goal masks, acting / stabilising roles, one network
trained from scratch that acts in the benchmark."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bimanualshift.data.episode import list_episodes, read_episode
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.methods.baselines.voxactb import (
    ROI_BOUNDS,
    ROI_LIFT,
    RoiEpisodes,
    VoxActBPolicy,
    roles_of_starts,
)
from bimanualshift.priors import UnimanualPrior
from bimanualshift.registry import TrainRequest, get_method
from bimanualshift.rollout.loop import rollout
from bimanualshift.sim.env import ManipulationEnv


def test_the_arm_nearer_the_region_acts() -> None:
    roles = roles_of_starts({"left": np.array([0.3, 0.2, 0.1]), "right": np.array([0.1, -0.1, 0.1])})
    assert roles == {"left": 1, "right": 0}


def test_the_region_is_centred_above_the_goal_objects(demo_root: Path) -> None:
    episode = read_episode(list_episodes(demo_root / "bimanual", "push_two_buttons")[0])
    moved = RoiEpisodes()(episode)
    centre = np.asarray(moved.arm_bases["left"])
    assert moved.arm_bases["left"] == moved.arm_bases["right"]
    obs = KeyframeObservation.from_episode(episode, 0)
    # the two named buttons' pixels: the region's centre lies above them, and every expert target is inside it
    targets = episode.arrays["actions"][:, :, :3].reshape(-1, 3) - centre
    low, high = np.asarray(ROI_BOUNDS[:3]), np.asarray(ROI_BOUNDS[3:])
    assert np.all((targets > low) & (targets < high)), targets
    assert centre[2] > obs.scene.arm_bases["left"][2] - 0.2 and ROI_LIFT > 0


def test_trains_and_acts(demo_root: Path, tmp_path: Path) -> None:
    request = TrainRequest(task="push_two_buttons", data=str(demo_root / "bimanual"),
                           validation_data=str(demo_root / "bimanual"), demos=2, prior="", out=str(tmp_path),
                           steps=2, overrides={"size": "debug", "checkpoint_every": 2})
    spec = get_method("voxactb")
    best = spec.train(request)
    model = UnimanualPrior.from_pretrained(best)
    assert model.config.proprio_dim == 18 and tuple(model.config.bounds) == ROI_BOUNDS
    policy = spec.load(best, request)
    assert isinstance(policy, VoxActBPolicy)
    env = ManipulationEnv("push_two_buttons", image_size=64)
    try:
        assert rollout(env, policy, seed=200_000, max_keyframes=2).keyframes == 2
        assert policy.centre is not None and sorted(policy.roles.values()) == [0, 1]
    finally:
        env.close()
