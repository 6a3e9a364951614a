"""The deployment loop: read the robot, ask the policy server, send the (clipped) keyframe, until the episode ends.

If the server goes away mid-episode the robot holds its pose and the episode is reported as aborted, with the
reason; the next episode reconnects first.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from tqdm import tqdm

from bimanualshift.deploy.client import PolicyClient, ServerError, ServerUnavailable
from bimanualshift.deploy.robot import Calibration, action_dict, action_rows, observation_from_robot
from bimanualshift.deploy.schema import SchemaError, action_from_reply, chunk_from_reply, observation_message
from bimanualshift.deploy.sim_robot import MujocoRobot
from bimanualshift.rollout.loop import KEYFRAME_BUDGET, EpisodeObserver, actions_digest


@dataclass
class DeployedEpisode:
    task: str
    seed: int
    success: bool
    keyframes: int
    stages_done: int
    aborted: str | None = None  # why the episode stopped early (the server went away, refused a request)
    clipped: int = 0  # commands the safety limits changed
    executed: list[list[list[float]]] = field(default_factory=list)  # per keyframe the (arms, 9) rows sent
    round_trip_ms: list[float] = field(default_factory=list)
    diagnostics: list[dict[str, Any]] = field(default_factory=list)  # the server's per-keyframe policy log
    # the policy's actions as the server sent them, digested as ``rollout`` digests its own (``actions_digest``):
    # equal digests mean the robot was sent what the benchmark's episode on this seed executed, bit for bit
    actions_sha256: str = ""


def run_sim_episode(robot: MujocoRobot, client: PolicyClient, seed: int, max_keyframes: int = 0,
                    observer: EpisodeObserver | None = None, chunk_steps: int = 1) -> DeployedEpisode:
    """One episode on ``seed`` within the benchmark's budget (``KEYFRAME_BUDGET`` x the expert's keyframes;
    ``max_keyframes`` caps it), every observation and action through the server's codec; ``observer`` sees each
    keyframe's observation, the action sent and the server's policy log. Where a reply carries a ``chunk`` (the
    policy planned several keyframes ahead), up to ``chunk_steps`` of its keyframes run before the robot is read
    again, each through the robot's safety filter; 1 asks the server at every keyframe, as the benchmark does."""
    if chunk_steps < 1:
        raise ValueError(f"chunk_steps {chunk_steps}: run at least the first keyframe of each reply (1)")
    context = robot.reset_episode(seed)
    budget = KEYFRAME_BUDGET * robot.expert_keyframe_count()
    budget = min(budget, max_keyframes) if max_keyframes else budget
    record = DeployedEpisode(robot.task_name, seed, False, 0, 0)
    replied: list[np.ndarray] = []
    root = observer.episode(robot.task_name, "deployed", seed, context.instruction) if observer else ""
    arms = list(robot.arm_names)
    done = False
    while record.keyframes < budget and not done:
        k = record.keyframes
        reading = robot.get_observation()
        obs = observation_from_robot(robot, reading, context, k)
        message = observation_message(obs, context.episode_id, with_maps=f"{robot.camera_names[0]}_instance" in reading)
        started = time.perf_counter()
        try:
            reply = client.infer(message)
            planned = [action_from_reply(reply, arms)]
            chunk = chunk_from_reply(reply, len(arms)) if chunk_steps > 1 else None
        except (ServerUnavailable, ServerError, SchemaError) as err:
            robot.hold()
            record.aborted = f"{type(err).__name__}: {err}"
            break
        record.round_trip_ms.append(1e3 * (time.perf_counter() - started))
        record.diagnostics.append(reply.get("diagnostics", {}))
        if chunk is not None:  # the keyframes after the first, as many as asked and the budget leaves
            planned += [chunk[:, j] for j in range(1, min(chunk.shape[1], chunk_steps, budget - k))]
        for j, rows in enumerate(planned):
            replied.append(rows)
            sent = robot.send_action(action_dict(rows, robot.arm_names))
            record.executed.append(action_rows(sent, robot.arm_names).tolist())
            record.clipped += sum(bool(sent[f"{arm}_clipped"]) for arm in robot.arm_names)
            record.keyframes, record.stages_done = record.keyframes + 1, robot.stages_done
            if observer is not None and j == 0:  # the observation the reply answered
                observer.keyframe(root, k, obs, {"keyframe": k, "executed": record.executed[-1], "expert": None,
                                                 "stages_done": robot.stages_done, "policy": record.diagnostics[-1],
                                                 "planned_ahead": len(planned) - 1})
            if robot.success or sent["truncated"]:
                done = True
                break
    record.success = robot.success
    record.actions_sha256 = actions_digest(replied)
    return record


def deploy_sim(task: str, client: PolicyClient, seeds: list[int], max_keyframes: int = 0,
               calibration: Calibration | None = None, observer: EpisodeObserver | None = None,
               chunk_steps: int = 1) -> list[DeployedEpisode]:
    robot = MujocoRobot(task, calibration=calibration)
    robot.connect()
    records = []
    try:
        for seed in tqdm(seeds, desc=f"deploy {task}", unit="ep"):
            if records and records[-1].aborted:
                client.reconnect()
            records.append(run_sim_episode(robot, client, seed, max_keyframes, observer, chunk_steps))
    finally:
        robot.disconnect()
    return records


def episode_row(record: DeployedEpisode) -> dict[str, Any]:
    row = asdict(record)
    row["round_trip_ms"] = [round(v, 1) for v in row["round_trip_ms"]]
    return row
