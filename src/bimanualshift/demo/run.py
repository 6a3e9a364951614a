"""Running the demo: collect, the prior, train the residual, evaluate, write the results."""

from __future__ import annotations

import json
import shlex
import shutil
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

import torch

from bimanualshift.data.collect import collect
from bimanualshift.data.seeds import split_seeds
from bimanualshift.demo import SHIPPED_PRIOR, DemoConfig
from bimanualshift.encoders.text import default_text_encoder
from bimanualshift.evaluation.bench import BenchJob, run_bench_episode
from bimanualshift.evaluation.media import write_strip, write_video
from bimanualshift.evaluation.report import success_rows, write_result
from bimanualshift.evaluation.tables import print_success_table
from bimanualshift.methods.bimanualshift import load_bimanualshift
from bimanualshift.methods.frozen_prior import FrozenPriorPerArm
from bimanualshift.registry import TrainRequest
from bimanualshift.rollout.loop import EpisodeRecord, rollout
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.training.configs import PretrainConfig, PriorDataConfig, ResidualDataConfig, TrainConfig
from bimanualshift.training.pretrain import pretrain
from bimanualshift.training.residual_trainer import changed_settings, train_residual
from bimanualshift.utils.workers import run_jobs


def ensure_prior(cfg: DemoConfig) -> str:
    """The prior to use: a checkpoint directory or shipped name, or one pretrained here if there is none."""
    shipped = SHIPPED_PRIOR.parent / cfg.prior
    path = Path(cfg.prior) if Path(cfg.prior).is_dir() or not shipped.is_dir() else shipped
    if (path / "model.safetensors").is_file():
        print(f"[demo] using the pretrained single-arm prior at {path}")
        return str(path)
    print(f"[demo] no prior at {cfg.prior}: pretraining one on single-arm demos (single-arm data only)")
    data, val = f"{cfg.workdir}/data/unimanual", f"{cfg.workdir}/data/unimanual_val"
    tasks = ["push_button", "pick_cube"]
    collect(tasks, split_seeds("train", 60), data, workers=cfg.workers)
    collect(tasks, split_seeds("validation", 8), val, workers=cfg.workers)
    best = pretrain(PretrainConfig(out=f"{cfg.workdir}/prior",
                                   dataset=PriorDataConfig(tasks=tasks, data=data, validation_data=val)))
    return str(best)


def residual_summary(run_dir: Path) -> dict:
    """The residual run's checkpoint choice and validation translation errors, for the result file."""
    summary = json.loads((run_dir / "summary.json").read_text())
    return {"best": summary["best"], "wall_time_s": summary["wall_time_s"],
            "validation_translation_error": summary["validation_translation_error"],
            "output_gate": summary.get("output_gate")}  # the residual's share kept, chosen on validation demos


def run_demo(cfg: DemoConfig) -> dict:
    started = time.time()
    command = " ".join(["bimanualshift demo", *(shlex.quote(a) for a in sys.argv[2:])])
    train_seeds = split_seeds("train", cfg.demos)
    val_seeds = split_seeds("validation", cfg.validation_demos)
    test_seeds = split_seeds("test", cfg.test_episodes)
    data, val_data = f"{cfg.workdir}/data/bimanual", f"{cfg.workdir}/data/bimanual_val"
    print(f"[demo] 1/4 collecting {cfg.demos} + {cfg.validation_demos} expert demos of {cfg.task}")
    stats = collect([cfg.task], train_seeds, data, workers=cfg.workers)
    collect([cfg.task], val_seeds, val_data, workers=cfg.workers)
    print("[demo] 2/4 frozen single-arm prior")
    prior_path = ensure_prior(cfg)
    print("[demo] 3/4 training the residual branch (prior and projection frozen)")
    train_cfg = TrainConfig(
        prior=prior_path, out=f"{cfg.workdir}/bimanualshift",
        dataset=ResidualDataConfig(task=cfg.task, data=data, validation_data=val_data, demos=cfg.demos),
        optim=replace(TrainConfig().optim, steps=cfg.residual_steps, seed=cfg.seed))
    changed = changed_settings(train_cfg)
    if changed:  # the demo's own scratch run, made by another version or settings: train afresh, never resume it
        print(f"[demo] {train_cfg.out} was trained with other settings ({', '.join(changed)}): training afresh")
        shutil.rmtree(train_cfg.out)
    best = train_residual(train_cfg)
    print(f"[demo] 4/4 evaluating on {cfg.test_episodes} held-out test seeds per method")
    # Test episodes in worker processes (an episode depends only on its policy, task and seed, so the pool changes
    # no outcome); then the first test episode of each method again here, recorded for the strip and the video.
    request = TrainRequest(task=cfg.task, data=data, validation_data=val_data, demos=cfg.demos, prior=prior_path,
                           out=str(best.parent), steps=cfg.residual_steps, seed=cfg.seed)
    methods = {"bimanualshift": str(best), "frozen_prior_per_arm": ""}
    jobs = [BenchJob(method, cfg.task, seed, checkpoint, asdict(request), max_keyframes=cfg.max_keyframes)
            for method, checkpoint in methods.items() for seed in test_seeds]
    episodes = sorted(run_jobs(run_bench_episode, jobs, cfg.workers, desc="demo test episodes", chunksize=1),
                      key=lambda e: (list(methods).index(e["method"]), e["seed"]))
    torch.set_num_threads(1)  # as the workers ran it, so the recorded episode is the one in the table
    text_encoder = default_text_encoder()
    env = ManipulationEnv(cfg.task)
    results = Path(cfg.results)
    results.mkdir(parents=True, exist_ok=True)
    for policy in (load_bimanualshift(best, text_encoder), FrozenPriorPerArm.from_pretrained(prior_path, text_encoder)):
        frames = rollout(env, policy, test_seeds[0], cfg.max_keyframes, record_camera="front").frames
        write_strip(results / f"{policy.name}_rollout.png", frames)
        write_video(results / f"{policy.name}_rollout.mp4", frames)
    env.close()
    records = [EpisodeRecord(e["method"], e["task"], e["seed"], bool(e["success"]), int(e["keyframes"]),
                             e["instruction"], stages_done=int(e["stages_done"])) for e in episodes]
    rows = success_rows(records, demos=cfg.demos)
    print_success_table(rows, f"{cfg.task}: {cfg.demos} demos, {cfg.test_episodes} test episodes")
    write_result(results / "summary.json", command, {"train": train_seeds, "validation": val_seeds,
                                                     "test": test_seeds}, started, rows,
                 notes=f"prior: {prior_path}; expert demos collected: {stats[cfg.task]}; "
                       f"episodes stop after {cfg.max_keyframes} keyframes",
                 residual_training=residual_summary(best.parent),
                 episodes=[{"method": r.method, "seed": r.seed, "success": r.success, "keyframes": r.keyframes,
                            "instruction": r.instruction} for r in records])
    print(f"[demo] done in {time.time() - started:.0f} s; results in {results}/")
    return {"rows": rows}
