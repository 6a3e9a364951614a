"""Closed-loop evaluation: a bimanual policy acting keyframe by keyframe in a task's environment."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from tqdm import tqdm

from bimanualshift.data.frames import KeyframeObservation, scene_of_env
from bimanualshift.sim.env import ManipulationEnv


class Policy(Protocol):
    name: str

    def reset(self) -> None: ...

    def act(self, obs: KeyframeObservation) -> np.ndarray: ...


@dataclass
class EpisodeRecord:
    method: str
    task: str
    seed: int
    success: bool
    keyframes: int
    instruction: str
    frames: list[np.ndarray] = field(default_factory=list, repr=False)
    stages_done: int = 0  # leading stages of a multi-stage task reached (``Task.stage_names``)


def rollout(env: ManipulationEnv, policy: Policy, seed: int, max_keyframes: int, record_camera: str | None = None
            ) -> EpisodeRecord:
    obs, _ = env.reset(seed=seed)
    scene = scene_of_env(env)
    policy.reset()
    frames = [obs["cameras"][record_camera]["rgb"]] if record_camera else []
    success, stages_done = False, 0
    for _ in range(max_keyframes):
        action = policy.act(KeyframeObservation.from_env(obs, scene))
        obs, _, success, truncated, info = env.step(action)
        stages_done = int(info["stages_done"])
        if record_camera:
            frames.append(obs["cameras"][record_camera]["rgb"])
        if success or truncated:
            break
    return EpisodeRecord(policy.name, env.task.name, seed, bool(success), env.keyframe_index,
                         env.task.instruction(), frames, stages_done)


def evaluate(env: ManipulationEnv, policy: Policy, seeds: list[int], max_keyframes: int,
             record_camera: str | None = None, record_episodes: int = 1) -> list[EpisodeRecord]:
    records = []
    bar = tqdm(seeds, desc=f"eval {policy.name}", unit="ep")
    for i, seed in enumerate(bar):
        records.append(rollout(env, policy, seed, max_keyframes, record_camera if i < record_episodes else None))
        bar.set_postfix(success=f"{np.mean([r.success for r in records]):.2f}")
    return records
