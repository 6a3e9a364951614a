"""The debug configuration end to end: pretrain 2 steps, resume to 4; train the residual 2 steps, resume to 4
(bit-identical to an uninterrupted run, prior untouched), then evaluate one episode."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file

from bimanualshift.encoders.text import default_text_encoder
from bimanualshift.methods.bimanualshift import load_bimanualshift
from bimanualshift.priors import UnimanualPrior
from bimanualshift.rollout.loop import rollout
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.training.checkpoint import latest_checkpoint
from bimanualshift.training.configs import PretrainConfig, TrainConfig
from bimanualshift.training.pretrain import pretrain
from bimanualshift.training.residual_trainer import train_residual
from bimanualshift.utils.config_files import config_from_flat


def pretrain_cfg(root: Path, out: Path, steps: int, prior: str = "peract") -> PretrainConfig:
    return config_from_flat(PretrainConfig, prior=prior, tasks=["push_button", "pick_cube"],
                            data=str(root / "unimanual"), validation_data=str(root / "unimanual"), out=str(out),
                            steps=steps, checkpoint_every=2, size="debug")


@pytest.fixture(scope="module")
def tiny_prior(demo_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("prior")
    pretrain(pretrain_cfg(demo_root, out, steps=2))
    return pretrain(pretrain_cfg(demo_root, out, steps=4))


def test_pretrain_resume_matches_uninterrupted(demo_root: Path, tiny_prior: Path, tmp_path: Path) -> None:
    resumed = load_file(str(latest_checkpoint(tiny_prior.parent) / "model.safetensors"))
    assert latest_checkpoint(tiny_prior.parent).name == "step_0000004"
    pretrain(pretrain_cfg(demo_root, tmp_path, steps=4))
    straight = load_file(str(latest_checkpoint(tmp_path) / "model.safetensors"))
    for key, value in straight.items():
        assert torch.equal(value, resumed[key]), key
    assert (tiny_prior / "config.json").is_file() and (tiny_prior / "model.safetensors").is_file()


def pretrain_resumed_and_straight(demo_root: Path, tmp_path: Path, prior: str) -> Path:
    """Pretrain ``prior`` 2 steps and resume to 4, and 4 steps straight: asserts the weights are bit-identical;
    returns the resumed run's best checkpoint."""
    pretrain(pretrain_cfg(demo_root, tmp_path / "a", steps=2, prior=prior))
    best = pretrain(pretrain_cfg(demo_root, tmp_path / "a", steps=4, prior=prior))
    pretrain(pretrain_cfg(demo_root, tmp_path / "b", steps=4, prior=prior))
    resumed = load_file(str(latest_checkpoint(tmp_path / "a") / "model.safetensors"))
    straight = load_file(str(latest_checkpoint(tmp_path / "b") / "model.safetensors"))
    for key, value in straight.items():
        assert torch.equal(value, resumed[key]), key
    return best


def test_diffusion_prior_pretrains_resumes_and_loads(demo_root: Path, tmp_path: Path) -> None:
    best = pretrain_resumed_and_straight(demo_root, tmp_path, "dp")
    prior = UnimanualPrior.from_pretrained(best)
    assert prior.config.type == "diffusion" and "Diffusion Policy" in (best / "README.md").read_text()
    assert torch.all(prior.action_low[:3] < prior.action_high[:3])  # normalisation fitted to the demos


def test_pretraining_refuses_bimanual_tasks_and_missing_data(demo_root: Path, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="bimanual tasks"):
        pretrain(config_from_flat(PretrainConfig, tasks=["push_two_buttons"], data=str(demo_root / "bimanual"),
                                  out=str(tmp_path)))
    with pytest.raises(FileNotFoundError, match="no single-arm demos for \\['slide_block'\\]"):
        pretrain(config_from_flat(PretrainConfig, tasks=["push_button", "slide_block"],
                                  data=str(demo_root / "unimanual"), out=str(tmp_path)))


def test_residual_training_resumes_keeps_prior_frozen_and_evaluates(demo_root: Path, tiny_prior: Path,
                                                                     tmp_path: Path) -> None:
    prior_before = load_file(str(tiny_prior / "model.safetensors"))

    def cfg(out: Path, steps: int) -> TrainConfig:
        # a constant rate: a cosine one is planned over --steps, so a run extended from 2 to 4 steps decays
        # differently from one asked for 4 (the schedule's own resume is tested with a warm-up below)
        return config_from_flat(TrainConfig, prior=str(tiny_prior), data=str(demo_root / "bimanual"),
                           validation_data=str(demo_root / "bimanual"), out=str(out), steps=steps,
                           checkpoint_every=2, demos=2, schedule="constant")

    prior = UnimanualPrior.from_pretrained(tiny_prior)
    prior_state = {k: v.clone() for k, v in prior.state_dict().items()}
    train_residual(cfg(tmp_path / "a", 2), prior=prior)
    best = train_residual(cfg(tmp_path / "a", 4), prior=prior)
    for key, value in prior_state.items():  # the in-memory prior the residual trained against is untouched
        assert torch.equal(value, prior.state_dict()[key]), key
    assert not any(p.requires_grad for p in prior.parameters()) and not prior.training
    train_residual(cfg(tmp_path / "b", 4))
    resumed = load_file(str(latest_checkpoint(tmp_path / "a") / "model.safetensors"))
    straight = load_file(str(latest_checkpoint(tmp_path / "b") / "model.safetensors"))
    assert set(resumed) == set(straight)
    for key in straight:
        assert torch.equal(straight[key], resumed[key]), key
    # Only the residual learned: the residual checkpoint holds no prior weights and the prior is unchanged.
    assert not any(k.startswith("prior") for k in resumed)
    prior_after = load_file(str(tiny_prior / "model.safetensors"))
    for key, value in prior_before.items():
        assert torch.equal(value, prior_after[key]), key

    policy = load_bimanualshift(best, default_text_encoder())
    rc = policy.residual.config
    assert rc.goal_dim > 0 and rc.phase_dim > 0 and rc.normalise_inputs  # the defaults read the goal and phase
    assert not torch.equal(policy.residual.input_std, torch.ones_like(policy.residual.input_std))  # fitted
    gate = json.loads((tmp_path / "a" / "summary.json").read_text())["output_gate"]  # chosen on validation
    assert torch.equal(policy.residual.output_scale, torch.tensor([gate["translation_scale"], gate["rotation_scale"]]))
    assert json.loads((best / "config.json").read_text())["output_scale"]["translation_scale"] == gate[
        "translation_scale"]
    from bimanualshift.demo.run import residual_summary

    assert residual_summary(tmp_path / "a")["output_gate"] == gate  # the demo's result file reports it
    env = ManipulationEnv("push_two_buttons", image_size=64)
    try:
        record = rollout(env, policy, seed=200_000, max_keyframes=1)
    finally:
        env.close()
    assert record.keyframes == 1 and record.method == "bimanualshift"


def test_prior_report_measures_a_trained_prior(tiny_prior: Path) -> None:
    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.evaluation.priors import evaluate_priors, prior_rows
    from bimanualshift.rollout.loop import KEYFRAME_BUDGET

    seeds = split_seeds("test", 2)
    episodes = evaluate_priors([str(tiny_prior)], ["push_button"], seeds)
    assert [e.seed for e in episodes] == seeds
    env = ManipulationEnv("push_button")
    env.reset(seed=seeds[0], options={"render": False})
    assert all(e.success or e.keyframes == KEYFRAME_BUDGET * len(env.expert_keyframes()) for e in episodes[:1])
    (row,) = prior_rows([str(tiny_prior)], episodes, ["push_button"], seeds[0])
    assert row["type"] == "peract" and row["tasks"]["push_button"]["episodes"] == 2
    assert row["parameters"] == sum(p.numel() for p in UnimanualPrior.from_pretrained(tiny_prior).parameters())
    assert row["inference_ms_per_arm"] > 0 and row["training_time_s"] is not None


def test_retrieval_trains_saves_its_frozen_memory_and_acts(demo_root: Path, tiny_prior: Path, tmp_path: Path
                                                           ) -> None:
    from bimanualshift.memory.bank import MemoryBank
    from bimanualshift.methods.bimanualshift import MEMORY_FILE

    best = train_residual(config_from_flat(TrainConfig, prior=str(tiny_prior), data=str(demo_root / "bimanual"),
                                      validation_data=str(demo_root / "bimanual"), out=str(tmp_path), steps=2,
                                      checkpoint_every=2, demos=2, retrieval=True, retrieval_threshold=-1.0))
    bank = MemoryBank.load(best / MEMORY_FILE)
    assert len(bank) == 2 and bank.entries[0].source == "demo" and bank.entries[0].task == "push_two_buttons"
    policy = load_bimanualshift(best, default_text_encoder())
    assert policy.memory.frozen and policy.residual.config.reference_dim > 0
    env = ManipulationEnv("push_two_buttons", image_size=64)
    try:
        record = rollout(env, policy, seed=200_000, max_keyframes=1)
    finally:
        env.close()
    assert record.keyframes == 1 and policy.retrieval is not None  # threshold -1: always a reference
    policy.reset()
    assert policy.retrieval is None


def test_continual_run_starts_from_the_earlier_run_and_keeps_its_memory(demo_root: Path, tiny_prior: Path,
                                                                         tmp_path: Path) -> None:
    from safetensors.torch import load_file

    from bimanualshift.memory.bank import MemoryBank
    from bimanualshift.methods.bimanualshift import MEMORY_FILE

    def cfg(out: str, **kw: object) -> TrainConfig:
        return config_from_flat(TrainConfig, prior=str(tiny_prior), data=str(demo_root / "bimanual"),
                           validation_data=str(demo_root / "bimanual"), out=str(tmp_path / out), steps=2,
                           checkpoint_every=2, demos=2, retrieval=True, retrieval_threshold=-1.0, **kw)

    first = train_residual(cfg("first", lr=5e-2))
    # A negligible lr (LAMB refuses 0): the continued run hands on the weights it started from.
    second = train_residual(cfg("second", lr=1e-12, init_from=str(tmp_path / "first"), seed=1))
    a, b = load_file(str(first / "model.safetensors")), load_file(str(second / "model.safetensors"))
    assert a.keys() == b.keys()
    for k in a:
        torch.testing.assert_close(a[k], b[k], atol=1e-6, rtol=0)
    fresh = load_file(str(train_residual(cfg("fresh", lr=1e-12, seed=1)) / "model.safetensors"))
    assert not all(torch.allclose(a[k], fresh[k], atol=1e-6) for k in a)  # without init_from it starts elsewhere
    bank = MemoryBank.load(second / MEMORY_FILE)
    assert len(bank) == 4  # this task's two demos first, then the earlier run's entries
    with pytest.raises(ValueError, match="residual config"):
        train_residual(cfg("mismatch", init_from=str(first), structured=False))
    with pytest.raises(FileNotFoundError, match="no BimanualShift checkpoint"):
        train_residual(cfg("missing", init_from=str(tmp_path / "nowhere")))
    # a run saved before a switch existed held that switch's default: it still continues, unless this run turns it on
    import json
    saved = json.loads((first / "config.json").read_text())
    del saved["residual"]["heading_anchor"]
    (first / "config.json").write_text(json.dumps(saved))
    train_residual(cfg("older", lr=1e-12, init_from=str(tmp_path / "first"), seed=1))
    with pytest.raises(ValueError, match="residual config"):
        train_residual(cfg("anchored", init_from=str(first), heading_anchor=True))


def test_without_residual_ablation_keeps_the_projection(tiny_prior: Path) -> None:
    from bimanualshift.methods.frozen_prior import FrozenPriorPerArm

    encoder = default_text_encoder()
    baseline = FrozenPriorPerArm.from_pretrained(str(tiny_prior), encoder)
    # Named as the benchmark names it, so the demo's table cannot be read as the fine-tuned PerAct-LF.
    assert baseline.prior_step.builder.projection is None and baseline.name == "frozen_prior_per_arm"
    ablation = FrozenPriorPerArm.from_pretrained(str(tiny_prior), encoder, "no_residual", use_projection=True)
    assert ablation.prior_step.builder.projection is not None and ablation.name == "no_residual"


def test_residual_with_a_clip_text_encoder_trains_and_reloads(demo_root: Path, tiny_prior: Path, tmp_path: Path
                                                              ) -> None:
    from tests.encoders.test_text import tiny_clip

    spec = f"clip:{tiny_clip(tmp_path / 'clip')}"
    best = train_residual(config_from_flat(TrainConfig, prior=str(tiny_prior), data=str(demo_root / "bimanual"),
                                      validation_data=str(demo_root / "bimanual"), out=str(tmp_path / "run"),
                                      steps=2, checkpoint_every=2, demos=2, text_encoder=spec))
    policy = load_bimanualshift(best)
    # The skill basis, the Manager's instruction input and the memory keys use CLIP; the prior keeps MiniLM.
    assert policy.text_encoder.dim == 16 and policy.residual.config.text_dim == 16
    assert policy.residual.basis.z.shape[1] == 16 and policy.prior_step.text_encoder.dim == 384
    env = ManipulationEnv("push_two_buttons", image_size=64)
    try:
        assert rollout(env, policy, seed=200_000, max_keyframes=1).keyframes == 1
    finally:
        env.close()


def test_prior_report_chooses_on_validation_seeds_past_every_other_use(tiny_prior: Path, tmp_path: Path) -> None:
    """A candidate prior is compared on validation scenes no demo, benchmark rollout or rollout choice uses."""
    import json

    from bimanualshift.cli import main
    from bimanualshift.data.seeds import PRIOR_CHOICE_START, SPLIT_OFFSETS
    from bimanualshift.training.closed_loop_choice import SELECTION_ROLLOUT_START

    out = tmp_path / "choice.json"
    main(["prior-report", "--prior", str(tiny_prior), "--task", "push_button", "--episodes", "1", "--split",
          "validation", "--out", str(out)])
    seeds = json.loads(out.read_text())["seeds"]
    assert seeds == {"validation": [SPLIT_OFFSETS["validation"] + PRIOR_CHOICE_START]}
    assert PRIOR_CHOICE_START > SELECTION_ROLLOUT_START


def test_prior_report_resumes_from_its_episode_log(tiny_prior: Path, tmp_path: Path) -> None:
    import json
    import time

    from bimanualshift.evaluation.priors import evaluate_priors

    log = tmp_path / "episodes.jsonl"
    seeds = [200_000, 200_001]
    first = evaluate_priors([str(tiny_prior)], ["push_button"], seeds, log=log)
    lines = log.read_text().splitlines()
    assert len(lines) == 2 and "steps" not in json.loads(lines[0])
    # every episode's keyframes, in bench's layout, beside the episodes (what `keyframe_precision.py` reads)
    keyframes = [json.loads(line) for line in (tmp_path / "episodes.keyframes.jsonl").read_text().splitlines()]
    assert [(k["method"], k["seed"]) for k in keyframes] == [(str(tiny_prior), s) for s in seeds]
    assert [len(k["steps"]) for k in keyframes] == [e.keyframes for e in first]
    assert "expert" in keyframes[0]["steps"][0] and "reached" in keyframes[0]["steps"][0]
    log.write_text(lines[0] + "\n" + lines[1][:10])  # killed while writing the second record
    again = evaluate_priors([str(tiny_prior)], ["push_button"], seeds, log=log)
    assert again == first and len(log.read_text().splitlines()) == 3  # the cut line stays, ignored
    # Past its deadline a report runs nothing more and returns what the log holds.
    (tmp_path / "b.jsonl").write_text(json.dumps(vars(first[0]) if hasattr(first[0], "__dict__") else {}) + "\n")
    partial = evaluate_priors([str(tiny_prior)], ["push_button"], seeds, log=tmp_path / "b.jsonl",
                              deadline=time.time() - 1)
    assert partial == first[:1]


def test_rvt_prior_pretrains_resumes_and_serves_the_residual_frozen(demo_root: Path, tmp_path: Path) -> None:
    best = pretrain_resumed_and_straight(demo_root, tmp_path, "rvt")
    prior = UnimanualPrior.from_pretrained(best)
    assert prior.config.type == "rvt" and prior.observation == "points"
    before = {k: v.clone() for k, v in prior.state_dict().items()}
    train_residual(config_from_flat(TrainConfig, prior=str(best), data=str(demo_root / "bimanual"),
                                    validation_data=str(demo_root / "bimanual"), out=str(tmp_path / "residual"),
                                    steps=2, checkpoint_every=2, demos=2), prior=prior)
    assert all(torch.equal(v, prior.state_dict()[k]) for k, v in before.items())  # the frozen prior never learned


def test_a_residual_run_is_resumed_only_under_its_own_settings(demo_root: Path, tiny_prior: Path,
                                                                tmp_path: Path) -> None:
    from bimanualshift.training.residual_trainer import changed_settings

    def cfg(**extra: object) -> TrainConfig:
        return config_from_flat(TrainConfig, prior=str(tiny_prior), data=str(demo_root / "bimanual"),
                                validation_data=str(demo_root / "bimanual"), out=str(tmp_path / "run"),
                                checkpoint_every=2, demos=2, augment_copies=0, **{"steps": 2, **extra})

    assert changed_settings(cfg()) == []  # nothing there yet
    train_residual(cfg())
    assert changed_settings(cfg()) == [] and changed_settings(cfg(paper_literal=True)) == ["model.paper_literal"]
    assert changed_settings(cfg(steps=4)) == []  # more steps extend the run
    with pytest.raises(ValueError, match=r"other settings \(model.paper_literal\).*own --out"):
        train_residual(cfg(paper_literal=True))


def test_an_action_space_residual_trains_and_acts(demo_root: Path, tiny_prior: Path, tmp_path: Path) -> None:
    best = train_residual(config_from_flat(TrainConfig, prior=str(tiny_prior), data=str(demo_root / "bimanual"),
                                           validation_data=str(demo_root / "bimanual"), out=str(tmp_path), steps=4,
                                           checkpoint_every=2, demos=2, action_space=True, action_window=5,
                                           augment_copies=1))
    policy = load_bimanualshift(best, default_text_encoder())
    cfg = policy.residual.config
    assert cfg.action_space and cfg.lattice_cells == 125 and cfg.rotation_bins == 36 and not cfg.output_gate
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert "prior_plus_residual_median_m" in summary["validation_translation_error"]
    assert summary["validation_rotation_error"] == {}  # its rotation is the prior's bins, not a turn to measure
    env = ManipulationEnv("push_two_buttons", image_size=64)
    try:
        record = rollout(env, policy, seed=200_000, max_keyframes=1)
    finally:
        env.close()
    assert record.keyframes == 1


def test_residual_training_follows_the_learning_rate_schedule(demo_root: Path, tiny_prior: Path,
                                                              tmp_path: Path) -> None:
    """--schedule reaches the residual's optimiser: a cosine schedule with warm-up trains other weights than a
    constant rate, and its state resumes to the uninterrupted run's (within the 3 warm-up steps the rate does not
    depend on the run's length, so a run extended from 2 to 4 steps matches one asked for 4)."""
    from safetensors.torch import load_file

    def cfg(out: str, steps: int, schedule: str) -> TrainConfig:
        return config_from_flat(TrainConfig, prior=str(tiny_prior), data=str(demo_root / "bimanual"),
                                validation_data=str(demo_root / "bimanual"), out=str(tmp_path / out), steps=steps,
                                checkpoint_every=2, demos=2, schedule=schedule, warmup_steps=3, lr=5e-2)

    prior = UnimanualPrior.from_pretrained(tiny_prior)
    for name, schedule in (("constant", "constant"), ("cosine", "cosine")):
        train_residual(cfg(name, 4, schedule), prior=prior)
    train_residual(cfg("resumed", 2, "cosine"), prior=prior)
    train_residual(cfg("resumed", 4, "cosine"), prior=prior)
    weights = {name: load_file(str(latest_checkpoint(tmp_path / name) / "model.safetensors"))
               for name in ("constant", "cosine", "resumed")}
    assert any(not torch.equal(v, weights["cosine"][k]) for k, v in weights["constant"].items())
    for key, value in weights["cosine"].items():
        assert torch.equal(value, weights["resumed"][key]), key
    # the summary breaks the validation error down by keyframe (from the Manager rows' phase one-hot)
    report = json.loads((tmp_path / "cosine" / "summary.json").read_text())["validation_translation_error"]
    per = report["per_keyframe"]
    assert per["keyframes"] == sorted(per["keyframes"]) and per["keyframes"][0] == 0
    for name in ("prior", "prior_plus_residual"):
        assert len(per[f"{name}_median_m"]) == len(per["keyframes"])
        assert min(per[f"{name}_median_m"]) <= report[f"{name}_median_m"] <= max(per[f"{name}_median_m"])
    # and the rotation error by arm and keyframe (a large turn learnt only in part shows at its keyframe)
    rotation = json.loads((tmp_path / "cosine" / "summary.json").read_text())["validation_rotation_error"]
    assert sorted(k for k in rotation if k.startswith("arm_")) == ["arm_0_per_keyframe", "arm_1_per_keyframe"]
    for arm in ("arm_0_per_keyframe", "arm_1_per_keyframe"):
        assert len(rotation[arm]["prior_plus_residual_median_rad"]) == len(rotation[arm]["keyframes"])
    assert rotation["prior_median_rad"] >= 0 and rotation["prior_plus_residual_median_rad"] >= 0


def test_first_keyframes_goal_is_read_at_every_keyframe_and_reset(demo_root: Path, tiny_prior: Path,
                                                                  tmp_path: Path) -> None:
    from bimanualshift.data.episode import list_episodes, read_episode
    from bimanualshift.data.frames import KeyframeObservation
    from bimanualshift.perception.goal_geometry import GOAL_GEOMETRY_DIM, UNION_GEOMETRY_DIM

    best = train_residual(config_from_flat(TrainConfig, prior=str(tiny_prior), data=str(demo_root / "bimanual"),
                                           validation_data=str(demo_root / "bimanual"), out=str(tmp_path), steps=2,
                                           checkpoint_every=2, demos=2, goal_at_start=True))
    policy = load_bimanualshift(best, default_text_encoder())
    columns = policy.residual.config.layout()["start_goal"]
    assert policy.residual.config.start_goal_dim == GOAL_GEOMETRY_DIM
    episodes = [read_episode(p) for p in list_episodes(demo_root / "bimanual", "push_two_buttons")[:2]]
    first = policy.decide(KeyframeObservation.from_episode(episodes[0], 0))
    for decision in first:  # at keyframe 0 the first goal is the current one
        torch.testing.assert_close(decision.inputs[columns], torch.as_tensor(decision.step.goal))
        assert decision.inputs[columns].any()
    # it reads each goal noun's own box, so the loaded step computes them (both buttons, seen by some arm)
    assert any(decision.step.goal[UNION_GEOMETRY_DIM:].any() for decision in first)
    last = episodes[0].num_keyframes - 1
    later = policy.decide(KeyframeObservation.from_episode(episodes[0], last))
    for decision, start in zip(later, first, strict=True):  # later keyframes keep reading keyframe 0's
        torch.testing.assert_close(decision.inputs[columns], start.inputs[columns])
    policy.reset()  # a new episode reads its own first keyframe
    other = policy.decide(KeyframeObservation.from_episode(episodes[1], 0))
    for decision in other:
        torch.testing.assert_close(decision.inputs[columns], torch.as_tensor(decision.step.goal))
    assert not torch.equal(other[0].inputs[columns], first[0].inputs[columns])
