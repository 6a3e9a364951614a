"""A chunk-predicting prior's planned keyframes reach the robot: the frozen prior per arm exposes them as world
rows whose first is the action it executes, and a PerAct-style prior, which plans one keyframe, exposes none."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from bimanualshift.configs import PRIOR_SIZES
from bimanualshift.data.episode import list_episodes, read_episode
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.encoders.text import default_text_encoder
from bimanualshift.methods.frozen_prior import FrozenPriorPerArm
from bimanualshift.methods.prior_step import FrozenPriorStep
from bimanualshift.priors.diffusion.configuration_diffusion import DiffusionConfig
from bimanualshift.priors.diffusion.modeling_diffusion import DiffusionPrior
from bimanualshift.priors.peract.configuration_peract import PerActConfig
from bimanualshift.priors.peract.modeling_peract import PerActPrior


def test_the_planned_keyframes_come_as_world_rows(demo_root: Path) -> None:
    episode = read_episode(list_episodes(demo_root / "bimanual", "push_two_buttons")[0])
    obs = KeyframeObservation.from_episode(episode, 0)
    encoder = default_text_encoder()
    torch.manual_seed(0)
    diffusion = DiffusionPrior(DiffusionConfig(**{**PRIOR_SIZES["diffusion"]["debug"], "horizon": 3}))
    policy = FrozenPriorPerArm(FrozenPriorStep(diffusion.freeze(), encoder))
    policy.reset()
    assert policy.action_chunk() is None  # nothing planned before the first act
    action = policy.act(obs)
    chunk = policy.action_chunk()
    assert chunk.shape == (2, 3, 9) and chunk.dtype == np.float32
    assert np.array_equal(chunk[:, 0], action)  # the first planned keyframe is the one executed
    assert np.allclose(np.linalg.norm(chunk[:, :, 3:7], axis=-1), 1, atol=1e-5)
    assert set(np.unique(chunk[:, :, 7])) <= {0.0, 1.0}
    peract = FrozenPriorPerArm(FrozenPriorStep(PerActPrior(PerActConfig(**PRIOR_SIZES["peract"]["debug"])).freeze(),
                                               encoder))
    peract.reset()
    peract.act(obs)
    assert peract.action_chunk() is None
