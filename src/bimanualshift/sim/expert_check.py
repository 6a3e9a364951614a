"""Measure every task's scripted expert: success rate, wall time and keyframes per episode (no rendering)."""

from __future__ import annotations

import time
from dataclasses import dataclass

from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.env_cache import cached_env
from bimanualshift.utils.workers import run_jobs


@dataclass(frozen=True)
class ExpertEpisode:
    task: str
    seed: int
    success: bool
    keyframes: int
    wall_time_s: float


def run_expert(env: ManipulationEnv, seed: int) -> ExpertEpisode:
    started = time.perf_counter()
    env.reset(seed=seed, options={"render": False})
    keyframes = env.expert_keyframes()
    for keyframe in keyframes:
        env.step(env.action_from_keyframe(keyframe), render=False)
    return ExpertEpisode(env.task.name, seed, env.success(), len(keyframes), time.perf_counter() - started)


def _run_job(job: tuple[str, str, int]) -> ExpertEpisode:
    task, perturbation, seed = job
    return run_expert(cached_env(task, perturbation, image_size=64), seed)


def check_experts(tasks: list[str], seeds: list[int], workers: int = 1, executor: str = "local",
                  perturbation: str = "none") -> list[ExpertEpisode]:
    """Every task's expert on every seed, under a perturbation preset (``sim.perturbations.PRESETS``)."""
    jobs = [(task, perturbation, seed) for task in tasks for seed in seeds]
    results = run_jobs(_run_job, jobs, workers, desc="expert episodes", executor=executor)
    return sorted(results, key=lambda e: (e.task, e.seed))
