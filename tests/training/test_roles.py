"""`--roles true`: the demos' roles (the arm that moves first leads), the assigner fitted on them, the (role, arm)
phase one-hot, and a run that records its assigner and decides roles again at inference."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from bimanualshift.encoders.text import default_text_encoder
from bimanualshift.methods.bimanualshift import load_bimanualshift
from bimanualshift.methods.role_assigner import RoleAssigner
from bimanualshift.perception.arm_samples import ArmSamples
from bimanualshift.residual.manager import ResidualConfig, arm_and_slot, manager_input_rows, phase_one_hot
from bimanualshift.training.configs import TrainConfig
from bimanualshift.training.residual_trainer import train_residual
from bimanualshift.training.roles import assigned_roles, demo_roles, fit_role_assigner
from bimanualshift.utils.config_files import config_from_flat
from tests.training.test_prior_instruction import first_observation


def samples_of(episodes: list[tuple[str, str]], goal_y: list[float]) -> tuple[ArmSamples, np.ndarray]:
    """Two-arm episodes given as each arm's hold string over keyframes 1.. ('H' holds), keyframe 0 first; the
    goal's y in both arms' frames is ``goal_y`` per episode (what tells the roles apart)."""
    rows: dict[str, list] = {k: [] for k in ("episode", "keyframe", "arm", "hold", "goal")}
    for e, (left, right) in enumerate(episodes):
        for k in range(len(left) + 1):
            for arm, holds in (("left", left), ("right", right)):
                rows["episode"].append(e)
                rows["keyframe"].append(k)
                rows["arm"].append(arm)
                rows["hold"].append(float(k > 0 and holds[k - 1] == "H"))
                goal = np.zeros(3)
                goal[1] = goal_y[e] + (0.6 if arm == "left" else 0.0)  # the arms' frames are 0.6 m apart
                rows["goal"].append(goal)
    n = len(rows["arm"])
    samples = ArmSamples(voxels=None, proprio=np.zeros((n, 9), np.float32), instructions=["x"] * n,
                         action_pos=np.zeros((n, 3), np.float32), action_quat=np.tile([0, 0, 0, 1.0], (n, 1)),
                         gripper_open=np.ones(n, np.int64), ignore_collisions=np.zeros(n, np.int64),
                         episode=np.asarray(rows["episode"]), keyframe=np.asarray(rows["keyframe"]), arm=rows["arm"],
                         other_proprio=np.zeros((n, 8), np.float32), goal=np.asarray(rows["goal"], np.float32))
    return samples, np.asarray(rows["hold"], np.float32)


def test_the_arm_that_moves_first_leads_and_ties_go_to_the_first_arm() -> None:
    samples, holds = samples_of([("HH..", "..HH"), ("..HH", "HH.."), ("....", "....")], [0, 0, 0])
    roles = demo_roles(samples, holds)
    by = {(int(e), a): int(r) for e, a, r in zip(samples.episode, samples.arm, roles)}
    assert by == {(0, "left"): 1, (0, "right"): 0, (1, "left"): 0, (1, "right"): 1,
                  (2, "left"): 0, (2, "right"): 1}


def test_roles_in_arm_order_need_no_classifier() -> None:
    samples, holds = samples_of([("....", "HH.."), ("..HH", "HH..")], [0, 0.1])
    assigner = fit_role_assigner(samples, holds)
    assert assigner.chooser is None and assigner.assign(np.zeros((2, 5))).tolist() == [0, 1]
    assert RoleAssigner.from_dict(json.loads(json.dumps(assigner.to_dict()))).chooser is None
    swapped, swapped_holds = samples_of([("HH..", "...."), ("HHH.", "..HH")], [0, 0.1])  # the right arm always leads
    assert fit_role_assigner(swapped, swapped_holds).chooser is None


def test_the_assigner_learns_which_arm_leads_from_the_scene_and_exactly_one_leads() -> None:
    # the goal on the left (y > 0 in the right arm's frame): the right arm waits, and the other way round
    layout = [0.2, -0.2, 0.25, -0.25, 0.15, -0.15]
    episodes = [("..HH", "HH..") if y > 0 else ("HH..", "..HH") for y in layout]
    samples, holds = samples_of(episodes, layout)
    assigner = fit_role_assigner(samples, holds)
    assert assigner.chooser is not None and assigner.accuracy == 1.0
    truth = demo_roles(samples, holds)
    assert np.array_equal(assigned_roles(assigner, samples), truth)
    loaded = RoleAssigner.from_dict(json.loads(json.dumps(assigner.to_dict())))
    unseen, unseen_holds = samples_of([("HH..", "..HH"), ("..HH", "HH..")], [-0.3, 0.3])
    decided = assigned_roles(loaded, unseen)
    assert np.array_equal(decided, demo_roles(unseen, unseen_holds))
    for e in (0, 1):  # one leader per episode, even where each arm alone would be judged the same
        assert sorted(decided[(unseen.episode == e) & (unseen.keyframe == 0)].tolist()) == [0, 1]


def test_role_phase_gives_each_role_and_arm_its_own_block() -> None:
    cfg = ResidualConfig(phase_dim=4 * 3, role_phase=True)
    assert cfg.slots_per_arm == 3 and cfg.phase_blocks == 4
    arm, keyframe, role = torch.tensor([0, 1, 0, 1]), torch.tensor([0, 0, 5, 1]), torch.tensor([0, 0, 1, 1])
    index = phase_one_hot(cfg, keyframe, arm, role).argmax(-1)
    assert index.tolist() == [0, 3, 2 * 3 + 2, 3 * 3 + 1]  # role-major blocks of (role, arm); slots clamp at 2
    rows = torch.zeros(4, cfg.layout()["start_goal"].stop)
    rows[:, cfg.layout()["phase"]] = phase_one_hot(cfg, keyframe, arm, role)
    arms, slots = arm_and_slot(cfg, rows)
    assert arms.tolist() == [0, 1, 0, 1] and slots.tolist() == [0, 0, 2, 1]
    with pytest.raises(ValueError, match="role"):
        manager_input_rows(cfg, torch.zeros(1, cfg.feature_dim), torch.zeros(1, 9), torch.zeros(1, 8),
                           torch.zeros(1, cfg.text_dim), torch.zeros(1, 8), torch.tensor([0]), torch.tensor([0]))


@pytest.fixture(scope="module")
def prior_dir(demo_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    return pretrain(pretrain_cfg(demo_root, tmp_path_factory.mktemp("prior"), steps=2))


def alternating_roles(samples: ArmSamples, holds: np.ndarray) -> np.ndarray:
    """Roles that change from demo to demo (the left arm leads in even demos), as take tray's layout makes them."""
    left = np.array([a == "left" for a in samples.arm])
    return np.where(left == (np.asarray(samples.episode) % 2 == 0), 0, 1)


def roles_cfg(demo_root: Path, prior_dir: Path, out: Path, roles: bool) -> TrainConfig:
    return config_from_flat(TrainConfig, prior=str(prior_dir), data=str(demo_root / "bimanual"),
                            validation_data=str(demo_root / "bimanual"), out=str(out), steps=2,
                            checkpoint_every=2, demos=2, schedule="constant", roles=roles)


def test_a_roles_run_records_its_assigner_and_the_policy_decides_roles_at_the_first_keyframe(
        demo_root: Path, prior_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    for module in ("roles", "residual_trainer", "residual_data"):
        monkeypatch.setattr(f"bimanualshift.training.{module}.demo_roles", alternating_roles)
    best = train_residual(roles_cfg(demo_root, prior_dir, tmp_path, True))
    summary = json.loads((tmp_path / "summary.json").read_text())["roles"]
    assert not summary["by_arm_order"] and summary["validation_demos"] == 2
    saved = json.loads((best / "config.json").read_text())
    assert saved["residual"]["role_phase"] and saved["residual"]["phase_dim"] == 4 * 25
    policy = load_bimanualshift(best, default_text_encoder())
    assert policy.role_assigner is not None and policy.role_assigner.chooser is not None
    frame = first_observation()
    policy.reset()
    decisions = policy.decide(frame)
    roles = [entry["role"] for entry in policy.keyframe_log()["arms"]]
    assert sorted(roles) == [0, 1]
    cfg_r = policy.residual.config
    for i, d in enumerate(decisions):  # each arm's phase slot sits in its (role, arm) block
        block = int(d.inputs[cfg_r.layout()["phase"]].argmax()) // cfg_r.slots_per_arm
        assert block == roles[i] * cfg_r.num_arms + i


def test_roles_that_never_change_train_exactly_the_per_arm_residual(demo_root: Path, prior_dir: Path,
                                                                     tmp_path: Path) -> None:
    # push two buttons: each arm plays one role in every demo, so --roles true keeps the per-arm slots
    with_roles = train_residual(roles_cfg(demo_root, prior_dir, tmp_path / "roles", True))
    without = train_residual(roles_cfg(demo_root, prior_dir, tmp_path / "arms", False))
    assert json.loads((tmp_path / "roles" / "summary.json").read_text())["roles"]["by_arm_order"]
    saved = json.loads((with_roles / "config.json").read_text())
    assert not saved["residual"]["role_phase"] and saved["role_assigner"] is None
    a, b = (load_bimanualshift(d, default_text_encoder()).residual.state_dict() for d in (with_roles, without))
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
