"""How good the frozen single-arm priors are on their own (`bimanualshift prior-report`): success per single-arm
task with 95 % intervals, parameter count, inference time per call and training time."""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch

from bimanualshift.evaluation.stats import SuccessRate
from bimanualshift.utils.jsonl import append_record, read_records
from bimanualshift.utils.process_cache import cached
from bimanualshift.utils.workers import run_jobs


@dataclass(frozen=True)
class PriorEpisode:
    prior: str
    task: str
    seed: int
    success: bool
    keyframes: int
    # every keyframe's log (``rollout.loop.keyframe_row``); kept in a log of its own beside the episodes
    steps: list[dict[str, Any]] | None = field(default=None, compare=False, repr=False)


def keyframe_log_path(log: str | Path) -> Path:
    """Where a report's per-keyframe log goes, beside its episode log (``X.episodes.jsonl`` -> ``X.keyframes.jsonl``;
    bench's layout: one line per episode with the task, the prior as ``method`` and the keyframes)."""
    log = Path(log)
    stem = log.name[: -len(".episodes.jsonl")] if log.name.endswith(".episodes.jsonl") else log.stem
    return log.with_name(f"{stem}.keyframes.jsonl")


def _policy(prior: str) -> Any:
    from bimanualshift.encoders.text import default_text_encoder
    from bimanualshift.methods.frozen_prior import FrozenPriorPerArm

    return cached(("policy", prior), lambda: FrozenPriorPerArm.from_pretrained(prior, default_text_encoder(),
                                                                                name=prior))


def run_prior_episode(job: tuple[str, str, int]) -> PriorEpisode:
    from bimanualshift.rollout.loop import episode_budget, rollout
    from bimanualshift.sim.env_cache import cached_env

    torch.set_num_threads(1)  # one process per core
    prior, task, seed = job
    env = cached_env(task)
    record = rollout(env, _policy(prior), seed, episode_budget(env, seed))
    return PriorEpisode(prior, task, seed, record.success, record.keyframes, record.steps)


def evaluate_priors(priors: list[str], tasks: list[str], seeds: list[int], workers: int = 1,
                    log: str | Path | None = None, deadline: float | None = None,
                    executor: str = "local") -> list[PriorEpisode]:
    """Every (prior, task, seed) episode; with ``log`` each finished one is appended there at once and episodes
    already logged are not run again, so a stopped report resumes. Jobs go seed by seed over every task and prior,
    so a report stopped at ``deadline`` covers the same seeds for all of them."""
    done = {}
    if log is not None:
        for r in read_records(log):
            episode = PriorEpisode(**r)
            done[(episode.prior, episode.task, episode.seed)] = episode
    jobs = [(p, t, s) for s in seeds for t in tasks for p in priors if (p, t, s) not in done]

    def record(episode: PriorEpisode) -> None:
        if log is not None:
            if episode.steps is not None:  # first, so that an episode logged as done always has its keyframes
                append_record(keyframe_log_path(log), {"task": episode.task, "method": episode.prior,
                                                       "perturbation": "none", "seed": episode.seed,
                                                       "steps": episode.steps})
            append_record(log, {k: v for k, v in asdict(episode).items() if k != "steps"})

    results = run_jobs(run_prior_episode, jobs, workers, desc="prior episodes", chunksize=2, on_result=record,
                       executor=executor,
                       deadline=deadline)
    wanted = {(p, t, s) for s in seeds for t in tasks for p in priors}
    results += [e for k, e in done.items() if k in wanted]
    return sorted(results, key=lambda e: (e.prior, e.task, e.seed))


def inference_ms(prior: str, task: str, seed: int, calls: int = 20, threads: int = 2) -> float:
    """Median milliseconds of one ``predict`` call for one arm on real observations, with ``threads`` threads."""
    from bimanualshift.data.frames import KeyframeObservation, scene_of_env
    from bimanualshift.sim.env_cache import cached_env

    torch.set_num_threads(threads)
    policy = _policy(prior)
    prior_step = policy.prior_step
    env = cached_env(task)
    obs, _ = env.reset(seed=seed)
    frame = KeyframeObservation.from_env(obs, scene_of_env(env))
    per_arm = prior_step.builder.build(frame)
    arm = frame.scene.arm_names[0]
    voxels = torch.as_tensor(prior_step.prior.observation_input(per_arm[arm].voxels, per_arm[arm].points))[None]
    proprio = torch.as_tensor(np.r_[per_arm[arm].proprio, 0.0].astype(np.float32))[None]
    text = prior_step.text(frame.instruction)
    prior_step.prior.predict(voxels, proprio, text)  # warm-up
    times = []
    for _ in range(calls):
        t0 = time.perf_counter()
        prior_step.prior.predict(voxels, proprio, text)
        times.append(1000 * (time.perf_counter() - t0))
    return float(np.median(times))


def prior_rows(priors: list[str], episodes: list[PriorEpisode], tasks: list[str], seed: int) -> list[dict]:
    from bimanualshift.priors.base import resolve_prior_path
    from bimanualshift.sim.task_registry import task_class

    rows = []
    for prior in priors:
        path = resolve_prior_path(prior)
        config = json.loads((Path(path) / "config.json").read_text())
        model = _policy(prior).prior_step.prior
        per_task = {}
        for task in tasks:
            mine = [e for e in episodes if e.prior == prior and e.task == task]
            if not mine:
                raise ValueError(f"no finished episode of {prior} on {task} yet: let the report run longer")
            rate = SuccessRate.of(e.success for e in mine).fields()
            per_task[task] = {"success": rate["success"], "ci95": rate["ci95"], "episodes": rate["episodes"],
                              "failed_seeds": [e.seed for e in mine if not e.success]}
        original = [t for t in tasks if not task_class(t).added_skill]
        added = [t for t in tasks if task_class(t).added_skill]

        def mean(names: list[str], per_task: dict = per_task) -> float | None:
            return round(float(np.mean([per_task[t]["success"] for t in names])), 4) if names else None

        rows.append({
            "prior": prior, "type": config["type"],
            # the original nine single-arm tasks, apart from the skills added later (Task.added_skill)
            "mean_success": mean(original), "mean_success_added_skills": mean(added),
            "tasks": per_task, "parameters": sum(p.numel() for p in model.parameters()),
            "inference_ms_per_arm": round(inference_ms(prior, tasks[0], seed), 1),
            "training_time_s": config.get("training_time_s"), "trained_steps": config.get("trained_steps"),
        })
    return rows
