"""Refinement: stray detection, Eq. 10 targets from the expert corrector, and the full `refine` run
(corrections, successes into the memory bank, L_corr fine-tuning, resume, frozen prior)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch
from safetensors import safe_open
from safetensors.torch import load_file
from scipy.spatial.transform import Rotation

from bimanualshift.data.frames import KeyframeObservation, scene_of_env
from bimanualshift.encoders.text import default_text_encoder
from bimanualshift.geometry.frames import compose_rotation, nearest_grasp_twin, quat_to_euler_bins
from bimanualshift.memory.bank import MemoryBank
from bimanualshift.methods.bimanualshift import MEMORY_FILE, BimanualShift, load_bimanualshift
from bimanualshift.residual.heading_anchor import ANCHOR_WIDTH, FRAMES, goal_heading
from bimanualshift.residual.manager import action_lattice
from bimanualshift.rollout.loop import rollout
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.training.checkpoint import latest_checkpoint
from bimanualshift.training.configs import RefineConfig, TrainConfig
from bimanualshift.training.refine import (
    collect_refinement,
    expert_actions,
    refine,
    repeats,
    run_policy,
    strays,
)
from bimanualshift.training.residual_trainer import train_residual
from bimanualshift.utils.config_files import config_from_flat


def _row(pos: list[float], yaw_deg: float = 0.0, gripper: float = 1.0) -> np.ndarray:
    half = np.radians(yaw_deg) / 2
    return np.r_[pos, [0.0, 0.0, np.sin(half), np.cos(half)], gripper, 0.0]


def test_strays_on_position_angle_and_gripper() -> None:
    expert = _row([0.5, 0.0, 1.0])
    assert not strays(_row([0.51, 0.0, 1.0], 5.0), expert, 0.03, 20.0)
    assert strays(_row([0.54, 0.0, 1.0]), expert, 0.03, 20.0)
    assert strays(_row([0.5, 0.0, 1.0], 30.0), expert, 0.03, 20.0)
    assert strays(_row([0.5, 0.0, 1.0], gripper=0.0), expert, 0.03, 20.0)
    # a half turn about the approach axis is the same grasp; a quarter turn is not
    assert not strays(_row([0.5, 0.0, 1.0], 180.0), expert, 0.03, 20.0)
    assert not strays(_row([0.5, 0.0, 1.0], -170.0), expert, 0.03, 20.0)
    assert strays(_row([0.5, 0.0, 1.0], 90.0), expert, 0.03, 20.0)


@pytest.fixture(scope="module")
def trained(demo_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tests.training.test_train_resume import pretrain, pretrain_cfg

    root = tmp_path_factory.mktemp("refine")
    prior = pretrain(pretrain_cfg(demo_root, root / "prior", steps=2))
    return train_residual(config_from_flat(TrainConfig, prior=str(prior), data=str(demo_root / "bimanual"),
                                      validation_data=str(demo_root / "bimanual"), out=str(root / "residual"),
                                      steps=2, checkpoint_every=2, demos=2, retrieval=True,
                                      retrieval_threshold=-1.0))


def _fully_corrected(policy: BimanualShift, keyframes: int) -> tuple:
    """The first ``keyframes`` of push two buttons (seed 3) with tolerance 0, so every arm strays at every step
    and the expert drives the whole episode; then the policy's decisions at the first keyframe of the same scene.
    Returns (plan, trajectory, key, correction, first decisions)."""
    env = ManipulationEnv("push_two_buttons", image_size=64)
    try:
        plan = expert_actions(env, 3)[:keyframes]
        _, trajectory, key, correction = run_policy(env, policy, 3, len(plan), plan, 0.0, 0.0)
        obs, _ = env.reset(seed=3)
        policy.reset()
        first = policy.decide(KeyframeObservation.from_env(obs, scene_of_env(env)))
    finally:
        env.close()
    return plan, trajectory, key, correction, first


def test_corrector_targets_are_expert_minus_frozen_prior(trained: Path) -> None:
    policy = load_bimanualshift(trained, default_text_encoder())
    plan, trajectory, key, correction, first = _fully_corrected(policy, keyframes=2)
    assert len(correction.inputs) == 2 * len(plan) and key is not None
    for i, decision in enumerate(first):  # Eq. 10 at the first keyframe, per arm
        pos, quat = decision.step.frame.pose_to_arm(plan[0][i][:3], plan[0][i][3:7])
        base = decision.step.prior
        np.testing.assert_allclose(base.position[0].numpy() + correction.translation[i], pos, atol=1e-5)
        recomposed = compose_rotation(base.quat[0].numpy(), correction.rotation[i])
        assert abs(abs(float(np.dot(recomposed, quat))) - 1.0) < 1e-5
        torch.testing.assert_close(correction.inputs[i], decision.inputs)
        np.testing.assert_allclose(trajectory[0, i, :3], pos, atol=1e-5)  # the expert's action was executed
    # the coordination targets: the corrector's gripper, and a hold where it repeats the arm's previous action
    assert correction.gripper == [float(plan[k][i][7] > 0.5) for k in range(len(plan)) for i in range(2)]
    assert correction.hold[:2] == [0.0, 0.0]  # an episode's first keyframe is never a hold
    assert correction.hold[2:] == [float(repeats(plan[1][i], plan[0][i])) for i in range(2)]


def test_refine_corrects_grows_memory_resumes_and_keeps_prior_frozen(trained: Path, tmp_path: Path) -> None:
    meta = json.loads((trained / "config.json").read_text())
    prior_before = load_file(str(Path(meta["prior"]) / "model.safetensors"))
    bank_before = MemoryBank.load(trained / MEMORY_FILE)

    def cfg(steps: int) -> RefineConfig:
        return RefineConfig(checkpoint=str(trained), out=str(tmp_path), episodes=2, start=5, max_keyframes=2,
                            steps=steps, checkpoint_every=2)

    refine(cfg(2))
    scenes = sorted((tmp_path / "scenes").glob("*.safetensors"))
    assert [p.name for p in scenes] == ["seed_000005.safetensors", "seed_000006.safetensors"]
    stamps = [p.stat().st_mtime_ns for p in scenes]
    best = refine(cfg(4))  # resumes: scenes are not rolled out again, training continues from step 2
    assert [p.stat().st_mtime_ns for p in scenes] == stamps
    assert latest_checkpoint(tmp_path).name == "step_0000004"
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["scenes"] == 2
    # A 2-step residual solves at most a scene by chance in 2 keyframes; the expert corrector must have stepped in.
    assert summary["policy_successes"] < summary["scenes"] and summary["correction_samples"] > 0
    assert "correction" in summary["history"][-1]
    bank = MemoryBank.load(best / MEMORY_FILE)
    assert len(bank) == len(bank_before) + summary["inserted_into_memory"]
    # every verified success joins the memory: the policy's own and the corrected ones
    assert summary["inserted_into_memory"] == summary["policy_successes"] + summary["corrected_successes"]
    assert all(e.source == "refinement" for e in bank.entries[len(bank_before):])
    prior_after = load_file(str(Path(meta["prior"]) / "model.safetensors"))
    for key, value in prior_before.items():
        assert torch.equal(value, prior_after[key]), key
    assert json.loads((best / "config.json").read_text())["refined_from"] == str(trained)
    refined = load_bimanualshift(best, default_text_encoder())  # the refined checkpoint loads like a trained one
    # an episode's log names the entry it followed and where that entry came from (`bimanualshift explain`)
    (row,) = rollout(ManipulationEnv("push_two_buttons"), refined, seed=7, max_keyframes=1).steps
    found = row["policy"]["retrieval"]
    assert found["fired"] and found["source"] == bank.entries[found["entry"]].source
    assert found["source_seed"] == bank.entries[found["entry"]].seed


def test_scenes_rolled_out_in_two_workers_match_one(trained: Path, tmp_path: Path) -> None:
    policy = load_bimanualshift(trained, default_text_encoder())
    files = {}
    for workers in (1, 2):
        cfg = RefineConfig(checkpoint=str(trained), out=str(tmp_path / f"w{workers}"), episodes=2, start=5,
                           max_keyframes=2, workers=workers)
        paths = collect_refinement(cfg, policy, "push_two_buttons")["train"]
        assert [p.name for p in paths] == ["seed_000005.safetensors", "seed_000006.safetensors"]
        files[workers] = paths
    for one, two in zip(files[1], files[2]):
        with safe_open(str(one), framework="pt") as a, safe_open(str(two), framework="pt") as b:
            assert a.metadata() == b.metadata()
            assert set(a.keys()) == set(b.keys())
            for key in a.keys():  # a worker's torch threads may sum in another order: equal up to rounding
                torch.testing.assert_close(a.get_tensor(key), b.get_tensor(key), rtol=1e-4, atol=1e-5, msg=key)


def test_a_policy_with_parts_the_checkpoint_does_not_name_rolls_out_in_this_process(
        trained: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import bimanualshift.training.refine as refine_module

    def no_workers(*args: object, **kwargs: object) -> None:
        raise AssertionError("rolled out in workers, which rebuild the checkpoint's own text encoder")

    monkeypatch.setattr(refine_module, "run_jobs", no_workers)
    policy = load_bimanualshift(trained, default_text_encoder())
    cfg = RefineConfig(checkpoint=str(trained), out=str(tmp_path), episodes=2, start=5, max_keyframes=1, workers=2)
    paths = collect_refinement(cfg, policy, "push_two_buttons", in_process=True)
    assert paths["validation"] == [] and all(p.is_file() for p in paths["train"])
    with pytest.raises(AssertionError, match="rolled out in workers"):  # the same scenes, not done yet, go to workers
        collect_refinement(replace(cfg, out=str(tmp_path / "again")), policy, "push_two_buttons")


def test_an_action_space_residual_is_corrected_in_its_own_action_space(demo_root: Path, trained: Path,
                                                                       tmp_path: Path) -> None:
    prior = json.loads((trained / "config.json").read_text())["prior"]  # the module's tiny PerAct-style prior
    trained = train_residual(config_from_flat(TrainConfig, prior=prior, data=str(demo_root / "bimanual"),
                                              validation_data=str(demo_root / "bimanual"), out=str(tmp_path / "r"),
                                              steps=2, checkpoint_every=2, demos=2, retrieval=True,
                                              retrieval_threshold=-1.0, action_space=True, action_window=5))
    policy = load_bimanualshift(trained, default_text_encoder())
    plan, _, _, correction, first = _fully_corrected(policy, keyframes=1)
    targets = correction.action_space
    assert len(targets["target_cell"]) == len(correction.inputs) == 2
    lattice = action_lattice(policy.residual.config)
    for i, decision in enumerate(first):
        pos, quat = decision.step.frame.pose_to_arm(plan[0][i][:3], plan[0][i][3:7])
        cells = decision.step.prior.position[0] + lattice
        distances = (cells - torch.as_tensor(pos, dtype=torch.float32)).norm(dim=-1)
        # the target cell is the lattice cell nearest the corrector's position
        assert float(distances[targets["target_cell"][i]]) == pytest.approx(float(distances.min()))
        bins = quat_to_euler_bins(quat, policy.prior_step.prior.rotation_bin_degrees)
        assert targets["target_bins"][i].tolist() == bins.tolist()
        assert targets["prior_translation"][i].shape == (125,) and targets["prior_rotation"][i].shape[0] == 3
    best = refine(RefineConfig(checkpoint=str(trained), out=str(tmp_path / "refined"), episodes=1, start=5,
                               max_keyframes=2, steps=2, checkpoint_every=2))
    summary = json.loads((tmp_path / "refined" / "summary.json").read_text())
    assert summary["correction_samples"] > 0 and "correction" in summary["history"][-1]
    assert load_bimanualshift(best, default_text_encoder()).residual.config.action_space


def test_refinement_adds_to_the_memory_only_the_successes_memory_insert_names(trained: Path, tmp_path: Path) -> None:
    import shutil

    bank_before = MemoryBank.load(trained / MEMORY_FILE)
    base = RefineConfig(checkpoint=str(trained), out=str(tmp_path / "all"), episodes=2, start=5, max_keyframes=2,
                        steps=2, checkpoint_every=2)
    refine(base)
    everything = json.loads((tmp_path / "all" / "summary.json").read_text())
    assert everything["corrected_successes"] > 0  # else "corrected" below could not tell itself from "none"
    for mode, expected in (("corrected", everything["corrected_successes"]), ("none", 0)):
        out = tmp_path / mode
        shutil.copytree(tmp_path / "all" / "scenes", out / "scenes")  # the same rollouts, not rolled out again
        best = refine(replace(base, out=str(out), memory_insert=mode))
        summary = json.loads((out / "summary.json").read_text())
        assert summary["corrected_successes"] == everything["corrected_successes"]
        assert summary["inserted_into_memory"] == expected
        bank = MemoryBank.load(best / MEMORY_FILE)
        assert len(bank) == len(bank_before) + expected
        assert all(e.source == "refinement" for e in bank.entries[len(bank_before):])


def test_scenes_from_reuses_rollouts_of_the_same_checkpoint_and_refuses_others(trained: Path, tmp_path: Path) -> None:
    from bimanualshift.training.refine import reuse_scenes

    source = tmp_path / "source"
    (source / "scenes").mkdir(parents=True)
    base = RefineConfig(checkpoint=str(trained), out=str(source), episodes=2, start=5, max_keyframes=2)
    (source / "refine_config.json").write_text(json.dumps({**vars(base)}))
    (source / "scenes" / "seed_000005.safetensors").write_bytes(b"scene 5")
    variant = replace(base, out=str(tmp_path / "variant"), memory_insert="none", scenes_from=str(source))
    (tmp_path / "variant" / "scenes").mkdir(parents=True)
    (tmp_path / "variant" / "scenes" / "seed_000006.safetensors").write_bytes(b"own scene 6")
    assert reuse_scenes(variant) == 1  # only the scene it lacks
    assert (tmp_path / "variant" / "scenes" / "seed_000005.safetensors").read_bytes() == b"scene 5"
    assert (tmp_path / "variant" / "scenes" / "seed_000006.safetensors").read_bytes() == b"own scene 6"
    assert reuse_scenes(variant) == 0
    with pytest.raises(ValueError, match="differ from this refinement's in start"):
        reuse_scenes(replace(variant, start=7))
    with pytest.raises(FileNotFoundError, match="no refine_config.json"):
        reuse_scenes(replace(variant, scenes_from=str(tmp_path / "nowhere")))


def test_validation_scenes_corrections_pick_the_fine_tuning_step_and_stay_out_of_the_memory(
        trained: Path, tmp_path: Path) -> None:
    bank_before = MemoryBank.load(trained / MEMORY_FILE)
    # tolerance 0: every arm strays at every keyframe, so the validation scene yields corrections for sure
    cfg = RefineConfig(checkpoint=str(trained), out=str(tmp_path), episodes=1, start=5, max_keyframes=2, steps=4,
                       checkpoint_every=2, tolerance_m=0.0, tolerance_deg=0.0, validation_episodes=1,
                       validation_start=7, lambda_corr=0.5)
    best = refine(cfg)
    assert [p.name for p in (tmp_path / "validation_scenes").glob("*.safetensors")] == ["seed_100007.safetensors"]
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["validation_scenes"] == 1 and summary["validation_correction_samples"] > 0
    values = {}
    for row in summary["history"]:  # Eq. 13's weighting on the held-out scenes, at every checkpoint and step 0
        assert row["validation"] == pytest.approx(row["validation_demos_value"]
                                                  + 0.5 * row["validation_correction_value"])
        values[row["step"]] = row["validation"]
    assert set(values) == {0, 2, 4}
    assert summary["best"]["value"] == pytest.approx(min(values.values()))
    # only the training scene's success may join the memory, never a validation scene's
    bank = MemoryBank.load(best / MEMORY_FILE)
    assert len(bank) == len(bank_before) + summary["inserted_into_memory"]
    assert summary["inserted_into_memory"] <= summary["scenes"]
    assert all(e.seed < 100_000 for e in bank.entries[len(bank_before):])


def test_scenes_from_copies_validation_scenes_only_from_the_same_validation_seeds(trained: Path,
                                                                                 tmp_path: Path) -> None:
    from bimanualshift.training.refine import reuse_scenes

    source = tmp_path / "source"
    base = RefineConfig(checkpoint=str(trained), out=str(source), episodes=1, start=5, validation_episodes=1,
                        validation_start=7)
    for folder, seed in (("scenes", 5), ("validation_scenes", 100_007)):
        (source / folder).mkdir(parents=True)
        (source / folder / f"seed_{seed:06d}.safetensors").write_bytes(folder.encode())
    (source / "refine_config.json").write_text(json.dumps({**vars(base)}))
    same = replace(base, out=str(tmp_path / "same"), scenes_from=str(source))
    assert reuse_scenes(same) == 2
    assert (tmp_path / "same" / "validation_scenes" / "seed_100007.safetensors").read_bytes() == b"validation_scenes"
    other = replace(same, out=str(tmp_path / "other"), validation_start=8)
    assert reuse_scenes(other) == 1  # its validation scene is another seed: rolled out anew
    assert not list((tmp_path / "other" / "validation_scenes").glob("*.safetensors"))


def test_slot_twin_references_are_saved_and_steer_the_corrections(demo_root: Path, trained: Path,
                                                                  tmp_path: Path) -> None:
    prior = json.loads((trained / "config.json").read_text())["prior"]
    best = train_residual(config_from_flat(TrainConfig, prior=prior, data=str(demo_root / "bimanual"),
                                           validation_data=str(demo_root / "bimanual"), out=str(tmp_path / "r"),
                                           steps=2, checkpoint_every=2, demos=2, retrieval=True,
                                           retrieval_threshold=-1.0, rotation_target="slot_twin"))
    policy = load_bimanualshift(best, default_text_encoder())
    config = policy.residual.config
    assert config.rotation_target == "slot_twin" and len(config.twin_references) == 4 * config.phase_dim
    plan, _, _, correction, first = _fully_corrected(policy, keyframes=1)
    for i, decision in enumerate(first):
        _, quat = decision.step.frame.pose_to_arm(plan[0][i][:3], plan[0][i][3:7])
        target = compose_rotation(decision.step.prior.quat[0].numpy(), correction.rotation[i])
        # the corrector's orientation or its half-turn twin, whichever is nearer the arm's keyframe-0 reference
        chosen = nearest_grasp_twin(quat, config.twin_reference(i, 0))
        assert abs(abs(float(np.dot(target, chosen))) - 1.0) < 1e-5


def test_heading_anchors_are_fitted_saved_and_turn_the_base_the_corrections_are_relative_to(
        demo_root: Path, trained: Path, tmp_path: Path) -> None:
    prior = json.loads((trained / "config.json").read_text())["prior"]
    best = train_residual(config_from_flat(TrainConfig, prior=prior, data=str(demo_root / "bimanual"),
                                           validation_data=str(demo_root / "bimanual"), out=str(tmp_path / "h"),
                                           steps=2, checkpoint_every=2, demos=2, retrieval=True,
                                           retrieval_threshold=-1.0, heading_anchor=True))
    policy = load_bimanualshift(best, default_text_encoder())
    config = policy.residual.config
    assert config.heading_anchor and len(config.heading_anchors) == ANCHOR_WIDTH * config.phase_dim  # fitted
    # every slot anchored to one grasp in the goal's frame: each arm's first base orientation is then that grasp
    # turned by its goal's end direction, and the corrections are taken relative to it
    anchor = Rotation.from_euler("xz", [np.pi, 0.4]).as_quat()
    policy.residual.config = replace(config, heading_anchors=(FRAMES.index("goal"), *anchor) * config.phase_dim)
    plan, _, _, correction, first = _fully_corrected(policy, keyframes=1)
    for i, decision in enumerate(first):
        heading, seen = goal_heading(decision.step.goal[None])
        assert seen[0]
        expected = (Rotation.from_euler("z", heading[0]) * Rotation.from_quat(anchor)).as_quat()
        assert abs(abs(float(np.dot(decision.step.prior.quat[0].numpy(), expected))) - 1.0) < 1e-5
        _, quat = decision.step.frame.pose_to_arm(plan[0][i][:3], plan[0][i][3:7])
        target = compose_rotation(decision.step.prior.quat[0].numpy(), correction.rotation[i])
        assert abs(abs(float(np.dot(target, quat))) - 1.0) < 1e-5
