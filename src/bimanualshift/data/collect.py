"""Scripted-expert demonstration collection, optionally in parallel worker processes.

Workers use the ``spawn`` start method: forking after an OpenGL context exists crashes. Each worker
builds one environment and reuses it (soft resets) for all its episodes.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bimanualshift.data.episode import Episode, episode_is_current, episode_path, list_episodes, write_episode
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.env_cache import cached_env
from bimanualshift.utils.hub import is_hub_ref
from bimanualshift.utils.workers import run_jobs


def stack_observations(observations: list[dict], camera_names: tuple[str, ...]) -> dict[str, np.ndarray]:
    def per_camera(key: str, sub: str | None, dtype: str) -> np.ndarray:
        rows = []
        for obs in observations:
            src = obs["cameras"] if sub else obs[key]
            rows.append([src[c][sub] if sub else src[c] for c in camera_names])
        return np.asarray(rows, dtype=dtype)

    return {
        "rgb": per_camera("cameras", "rgb", "uint8"),
        "depth": per_camera("cameras", "depth", "float32"),
        "instance": per_camera("cameras", "instance", "int16"),
        "class": per_camera("cameras", "class", "int16"),
        "intrinsics": per_camera("intrinsics", None, "float64"),
        "extrinsics": per_camera("extrinsics", None, "float64"),
        "proprio": np.asarray([o["proprio"] for o in observations], dtype=np.float32),
    }


def episode_from_rollout(env: ManipulationEnv, seed: int, observations: list[dict], actions: list[np.ndarray],
                         success: bool, dense: dict[str, np.ndarray] | None = None) -> Episode:
    arrays = stack_observations(observations, env.camera_names)
    arrays["actions"] = np.asarray(actions, dtype=np.float32)
    return Episode(
        task=env.task.name, seed=seed, instruction=observations[0]["instruction"], success=success,
        arm_names=list(env.arm_names), camera_names=list(env.camera_names),
        instance_names=env.instances.names, class_names=env.instances.classes,
        goal_nouns=env.task.goal_nouns(),
        arm_bases={arm: list(f.position) for arm, f in env.arm_frames.items()}, arrays=arrays, dense=dense,
        instance_colours=env.instance_colours(),
    )


def record_expert_episode(env: ManipulationEnv, seed: int) -> Episode:
    obs, _ = env.reset(seed=seed)
    env.start_dense_recording()
    observations, actions = [], []
    success = False
    for keyframe in env.expert_keyframes():
        action = env.action_from_keyframe(keyframe)
        observations.append(obs)
        actions.append(action)
        obs, _, success, _, _ = env.step(action)
    # The success flag latches (a button pressed once stays pressed); check the final state too.
    return episode_from_rollout(env, seed, observations, actions, bool(success or env.success()),
                                dense=env.dense_trajectory())


@dataclass(frozen=True)
class CollectJob:
    task: str
    seed: int
    out: str
    image_size: int | None  # None: the task robot's cameras' own size


def _collect_one(job: CollectJob) -> tuple[str, int, bool]:
    env = cached_env(job.task, image_size=job.image_size)
    episode = record_expert_episode(env, job.seed)
    if episode.success:  # only verified successes become demonstrations
        write_episode(episode_path(job.out, job.task, job.seed), episode)
    return job.task, job.seed, episode.success


def collect(tasks: Iterable[str], seeds: Iterable[int], out: str | Path, workers: int = 1,
            image_size: int | None = None, skip_existing: bool = True,
            executor: str = "local") -> dict[str, dict[str, int]]:
    """Collect expert demos; returns per task {"attempted", "succeeded", "skipped"}. A dataset on the hub
    (``hf://datasets/...``) is read-only: its demos count as skipped and nothing is written."""
    if is_hub_ref(out):
        return {t: {"attempted": 0, "succeeded": 0, "skipped": len(list_episodes(out, t))} for t in tasks}
    jobs = []
    stats: dict[str, dict[str, int]] = {}
    for task in tasks:
        stats[task] = {"attempted": 0, "succeeded": 0, "skipped": 0}
        for seed in seeds:
            if skip_existing and episode_is_current(episode_path(out, task, seed)):
                stats[task]["skipped"] += 1
                continue
            jobs.append(CollectJob(task, int(seed), str(out), image_size))
    for task, _, ok in run_jobs(_collect_one, jobs, workers, desc="collect", chunksize=1, executor=executor):
        stats[task]["attempted"] += 1
        stats[task]["succeeded"] += int(ok)
    return stats
