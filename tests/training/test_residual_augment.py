"""The residual's SE(3) augmentation: each augmented copy moves the scene the frozen prior sees, the targets, both
arms' poses and the goal geometry by one rigid motion, so every relation between them is kept."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from bimanualshift.data.episode import list_episodes
from bimanualshift.encoders.text import default_text_encoder
from bimanualshift.methods.prior_step import FrozenPriorStep
from bimanualshift.priors import UnimanualPrior
from bimanualshift.training.augment import Se3Augmentation, transform_points, transform_scene
from bimanualshift.training.configs import ResidualModelConfig
from bimanualshift.training.residual_data import residual_data


@pytest.fixture(scope="module")
def prior_dir(demo_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    return pretrain(pretrain_cfg(demo_root, tmp_path_factory.mktemp("prior"), steps=2))


def test_augmented_copies_move_scene_targets_poses_and_goal_together(demo_root: Path, prior_dir: Path) -> None:
    prior = UnimanualPrior.from_pretrained(prior_dir)
    step = FrozenPriorStep(prior, default_text_encoder(), locate_goal=True, proposal_features=True)
    seen_scenes: list[torch.Tensor] = []
    predict = prior.predict

    def recording(voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor):  # noqa: ANN202
        seen_scenes.append(voxels.clone())
        return predict(voxels, proprio, text)

    prior.predict = recording  # type: ignore[method-assign]
    config = ResidualModelConfig(goal_extremities=True).residual_config(prior.feature_dim, 384,
                                                                         prior.proposal_feature_dim)
    paths = list_episodes(demo_root / "bimanual", "push_two_buttons")[:1]
    data = residual_data(config, paths, step, default_text_encoder(), None, Se3Augmentation(0.04, 15.0),
                         augment_copies=2, seed=0)
    n = len(data) // 3
    layout = config.layout()
    own = data.inputs[:, layout["proprio"]][:, :3]
    other = data.inputs[:, layout["other_proprio"]][:, :3]
    goal = data.inputs[:, layout["goal"]][:, :3]
    tips = [data.inputs[:, layout["goal"]][:, start:start + 3] for start in (10, 16)]  # the extremities' tips
    base = data.inputs[:, layout["base_action"]][:, :3]
    target = base + data.translation  # the expert's position in each copy's frame
    original, copies = slice(0, n), [slice(n, 2 * n), slice(2 * n, 3 * n)]
    for copy in copies:
        assert not torch.allclose(target[copy], target[original])  # the copy moved
        for a, b in ((target, own), (target, other), (target, goal), (own, other), (target, tips[0]),
                     (target, tips[1])):  # rigid: distances kept
            torch.testing.assert_close((a[copy] - b[copy]).norm(dim=-1), (a[original] - b[original]).norm(dim=-1),
                                       atol=1e-4, rtol=0)
    assert torch.equal(data.gripper[original], data.gripper[copies[0]])  # labels do not move
    # the scene the prior saw moved by the same motion: recover each sample's yaw and shift from its target and
    # its own gripper, and the prior's input is the original scene moved by exactly that
    scenes = torch.cat(seen_scenes)
    grid = step.builder.grid
    checked = 0
    for copy in copies:
        for i in range(n):
            j = copy.start + i
            u, v = (target[i] - own[i])[:2], (target[j] - own[j])[:2]
            if u.norm() < 0.05:
                continue  # too short a lever to read the yaw from
            yaw = torch.atan2(u[0] * v[1] - u[1] * v[0], u @ v)[None]
            shift = target[j] - transform_points(target[i][None], grid, yaw, torch.zeros(1, 3))[0]
            shift[2] = 0.0
            expected = transform_scene(scenes[i:i + 1], grid, yaw, shift[None])
            a, b = expected[0, 0] > 0, scenes[j, 0] > 0
            overlap = (a & b).sum() / (a | b).sum()  # of the occupied voxels (a voxel may round the other way)
            assert overlap > 0.98, (i, copy, float(overlap))
            checked += 1
    assert checked > n // 2
    assert data.inputs[:, layout["proposal"]].abs().sum() > 0  # the proposal features came along


def test_the_first_keyframes_goal_moves_with_each_copy(demo_root: Path, prior_dir: Path) -> None:
    from bimanualshift.perception.goal_geometry import GOAL_GEOMETRY_DIM

    prior = UnimanualPrior.from_pretrained(prior_dir)
    step = FrozenPriorStep(prior, default_text_encoder(), locate_goal=True, goal_objects=True, proposal_features=True)
    config = ResidualModelConfig(goal_at_start=True).residual_config(prior.feature_dim, 384, prior.proposal_feature_dim)
    assert config.start_goal_dim == GOAL_GEOMETRY_DIM
    paths = list_episodes(demo_root / "bimanual", "push_two_buttons")[:2]
    data = residual_data(config, paths, step, default_text_encoder(), None, Se3Augmentation(0.04, 15.0),
                         augment_copies=1, seed=0)
    n = len(data) // 2
    layout = config.layout()
    goal, start = data.inputs[:, layout["goal"]], data.inputs[:, layout["start_goal"]]
    keyframe = data.inputs[:, layout["phase"]].argmax(-1) % config.slots_per_arm
    arm = data.inputs[:, layout["arm"]].argmax(-1)
    # unmoved rows: the start goal is the goal of the same arm's first keyframe, and constant over the episode
    firsts = [i for i in range(n) if keyframe[i] == 0]
    assert len(firsts) == 2 * len(paths)
    for i in range(n):
        owner = max(f for f in firsts if f <= i and arm[f] == arm[i]) if keyframe[i] else i
        torch.testing.assert_close(start[i, :config.goal_dim], goal[owner])
    # each moved copy moves its start goal with the scene: distances to the target stay
    target = data.inputs[:, layout["base_action"]][:, :3] + data.translation
    seen = start[:n, 9] > 0
    moved, kept = (target[n:] - start[n:, :3]).norm(dim=-1), (target[:n] - start[:n, :3]).norm(dim=-1)
    torch.testing.assert_close(moved[seen], kept[seen], atol=1e-4, rtol=0)
    assert not torch.allclose(start[n:][seen], start[:n][seen])
