"""Closed-loop episodes: a bimanual policy acting keyframe by keyframe in a task's environment."""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from tqdm import tqdm

from bimanualshift.core.policy import Policy
from bimanualshift.core.threads import policy_threads
from bimanualshift.data.frames import KeyframeObservation, scene_of_env

if TYPE_CHECKING:  # the loop only calls the env's methods; importing it would import robosuite
    from bimanualshift.sim.env import ManipulationEnv

# Every evaluated episode stops at this multiple of the scripted expert's keyframe count on the same seed (an
# optional cap on top); the benchmark, `eval`, the prior report and the demo all use it.
KEYFRAME_BUDGET = 2


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
    # One entry per keyframe (``keyframe_row``): the executed action, the scripted expert's action at the same
    # index on this seed, the stages reached, the poses reached, and what the policy logs itself
    # (``KeyframeLogging``).
    steps: list[dict[str, Any]] = field(default_factory=list, repr=False)
    # SHA-256 (hex, first 16 digits) of every executed action's float32 bytes in order: two runs of an episode
    # executed bit-identical actions exactly when their digests match (the logged actions are rounded)
    actions_sha256: str = ""


def actions_digest(actions: list[np.ndarray]) -> str:
    """``EpisodeRecord.actions_sha256`` of a list of (arms, 9) action rows (the deployment loop uses it too)."""
    digest = hashlib.sha256()
    for action in actions:
        digest.update(np.ascontiguousarray(action, np.float32).tobytes())
    return digest.hexdigest()[:16]


def _rounded(rows: np.ndarray) -> list[list[float]]:
    return np.round(np.asarray(rows, np.float64), 4).tolist()


def keyframe_row(k: int, executed: np.ndarray, expert: np.ndarray | None, stages_done: int, policy: Policy,
                 reached: np.ndarray | None = None) -> dict[str, Any]:
    """A keyframe's log entry: the (arms, 9) world rows executed and the expert's at the same index (None past
    the expert's last keyframe), the stages reached after it, the (arms, 8) poses the arms ended at (position,
    quaternion, gripper open: where the motion went, which a contact or the arm's reach can keep from the
    command), and the policy's own log where it keeps one."""
    row: dict[str, Any] = {"keyframe": k, "executed": _rounded(executed),
                           "expert": None if expert is None else _rounded(expert), "stages_done": stages_done}
    if reached is not None:
        row["reached"] = _rounded(reached)
    log = getattr(policy, "keyframe_log", None)
    if callable(log):
        row["policy"] = log()
    return row


def episode_budget(env: ManipulationEnv, seed: int, cap: int = 0) -> int:
    """Keyframes an episode on ``seed`` may take: ``KEYFRAME_BUDGET`` x the expert's, at most ``cap`` (0: no cap)."""
    env.reset(seed=seed, options={"render": False})
    budget = KEYFRAME_BUDGET * len(env.expert_keyframes())
    return min(budget, cap) if cap else budget


# (keyframe index, observation) -> the (arms, 9) world-frame action executed; the default is ``policy.act``
ActFn = Callable[[int, KeyframeObservation], np.ndarray]


class EpisodeObserver(Protocol):
    """Watches episodes as they run (``evaluation.viewer.EpisodeRecorder``): told of each episode, then of each
    keyframe's observation and log row."""

    def episode(self, task: str, method: str, seed: int, instruction: str) -> str: ...

    def keyframe(self, root: str, k: int, obs: KeyframeObservation | None, row: dict[str, Any]) -> None: ...


def rollout(env: ManipulationEnv, policy: Policy, seed: int, max_keyframes: int, record_camera: str | None = None,
            act: ActFn | None = None, observer: EpisodeObserver | None = None) -> EpisodeRecord:
    """One episode of at most ``max_keyframes``; ``act`` replaces the policy's own action (refinement uses it to
    let the expert take over straying arms); ``observer`` sees every keyframe's observation and log row."""
    obs, _ = env.reset(seed=seed)
    scene = scene_of_env(env)
    # the scripted expert's plan from this initial state: what each keyframe is compared with in the log
    plan = [env.action_from_keyframe(kf) for kf in env.expert_keyframes()]
    policy.reset()
    frames = [obs["cameras"][record_camera]["rgb"]] if record_camera else []
    root = observer.episode(env.task.name, policy.name, seed, env.task.instruction()) if observer else ""
    success, stages_done, steps, actions = False, 0, [], []
    for k in range(max_keyframes):
        frame = KeyframeObservation.from_env(obs, scene)
        with policy_threads():  # an episode's outcome must not depend on the process's thread count
            action = act(k, frame) if act is not None else policy.act(frame)
        actions.append(np.array(action, np.float32))
        obs, _, success, truncated, info = env.step(action)
        stages_done = int(info["stages_done"])
        steps.append(keyframe_row(k, action, plan[k] if k < len(plan) else None, stages_done, policy,
                                  reached=obs["proprio"]))
        if observer is not None:
            observer.keyframe(root, k, frame, steps[-1])
        if record_camera:
            frames.append(obs["cameras"][record_camera]["rgb"])
        if success or truncated:
            break
    return EpisodeRecord(policy.name, env.task.name, seed, bool(success), env.keyframe_index,
                         env.task.instruction(), frames, stages_done, steps, actions_digest(actions))


def evaluate(env: ManipulationEnv, policy: Policy, seeds: list[int], max_keyframes: int = 0,
             record_camera: str | None = None, record_episodes: int = 1,
             observer: EpisodeObserver | None = None) -> list[EpisodeRecord]:
    """Episodes on ``seeds``, each within ``episode_budget`` (``max_keyframes`` caps it; 0: no cap), every one
    shown to ``observer``."""
    records = []
    bar = tqdm(seeds, desc=f"eval {policy.name}", unit="ep")
    for i, seed in enumerate(bar):
        budget = episode_budget(env, seed, max_keyframes)
        records.append(rollout(env, policy, seed, budget, record_camera if i < record_episodes else None,
                               observer=observer))
        bar.set_postfix(success=f"{np.mean([r.success for r in records]):.2f}", refresh=False)
    return records
