"""Where an episode's time goes: control, physics, cameras and the policy (writes results/sim_profile.json).

    .venv/bin/python benchmarks/sim_profile.py --label after

Per task, the scripted expert runs ``--episodes`` episodes twice:

* instrumented, rendering the six-camera observation at every keyframe as demo collection does:
  ``control_step_ms`` (one executor control step as the environment runs it, the task's hook included),
  ``physics_ms`` (the raw ``mj_step`` substeps of that same step, timed on a copy of its state),
  ``observation_ms`` (one observation: every camera's RGB, depth and segmentation and the lookups after),
  render time per camera and pass, and ``policy_ms`` (the frozen prior driving both arms on that observation);
* plain, as ``bimanualshift experts`` runs it (no camera): ``expert_episodes_per_min`` for one worker.

Rows carry a ``label`` (``before`` / ``after`` a change); a run replaces only the rows of its own label, so the
file keeps both sides of a comparison with the commit each was measured at.
"""

from __future__ import annotations

import argparse
import copy
import json
import time
from pathlib import Path
from statistics import median
from typing import Any

import mujoco
import numpy as np
from tqdm import tqdm

from bimanualshift.data.frames import KeyframeObservation, scene_of_env
from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.report import git_commit, machine
from bimanualshift.sim.arm_control import SUBSTEPS
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.task_registry import resolve_task_names
from bimanualshift.utils.io import atomic_write_json
from bimanualshift.utils.pipes import quiet_on_closed_pipe


class StepTimer:
    """Wraps an environment's control step: wall time of each step, and of its raw physics on a copy."""

    def __init__(self, env: ManipulationEnv) -> None:
        self.env = env
        self.control_ms: list[float] = []
        self.physics_ms: list[float] = []
        self._inner = env._control_step
        env._control_step = self  # type: ignore[method-assign]

    def __call__(self, command: np.ndarray) -> None:
        m, d = self.env.model, self.env.data
        scratch = copy.copy(d)
        t0 = time.perf_counter()
        mujoco.mj_step(m, scratch, SUBSTEPS)
        t1 = time.perf_counter()
        self._inner(command)
        t2 = time.perf_counter()
        self.physics_ms.append(1000 * (t1 - t0))
        self.control_ms.append(1000 * (t2 - t1))


def summary(values: list[float]) -> dict[str, float]:
    return {"mean": round(float(np.mean(values)), 3), "median": round(float(median(values)), 3)}


def profile_task(task: str, seeds: list[int], policy: Any | None) -> dict[str, Any]:
    env = ManipulationEnv(task)
    env.reset(seed=seeds[0])  # warm-up: the first render sets up the GL context
    timer = StepTimer(env)
    observation_ms: list[float] = []
    policy_ms: list[float] = []
    env.render_timings = {}
    scene = scene_of_env(env)
    for seed in seeds:
        env.reset(seed=seed, options={"render": False})
        for keyframe in env.expert_keyframes():
            env.step(env.action_from_keyframe(keyframe), render=False)
            t0 = time.perf_counter()
            obs = env.observe(render=True)
            observation_ms.append(1000 * (time.perf_counter() - t0))
            if policy is not None and len(policy_ms) < 6:
                t0 = time.perf_counter()
                policy.act(KeyframeObservation.from_env(obs, scene))
                policy_ms.append(1000 * (time.perf_counter() - t0))
    passes = {key: round(float(np.mean(v)), 3) for key, v in sorted(env.render_timings.items())}
    env.render_timings = None
    env._control_step = timer._inner  # type: ignore[method-assign]
    successes, started = 0, time.perf_counter()
    for seed in seeds:
        env.reset(seed=seed, options={"render": False})
        for keyframe in env.expert_keyframes():
            env.step(env.action_from_keyframe(keyframe), render=False)
        successes += env.success()
    minutes = (time.perf_counter() - started) / 60
    env.close()
    control, physics = summary(timer.control_ms), summary(timer.physics_ms)
    return {
        "task": task, "episodes": len(seeds), "control_steps": len(timer.control_ms),
        "control_step_ms": control["mean"], "control_step_ms_median": control["median"],
        "physics_ms": physics["mean"], "physics_ms_median": physics["median"],
        "control_over_physics": round(control["mean"] / physics["mean"], 2),
        "observation_ms": round(float(np.mean(observation_ms)), 1), "observations": len(observation_ms),
        "render_ms_per_camera_pass": passes,
        "policy_ms": round(float(np.median(policy_ms)), 1) if policy_ms else None,
        "expert_episodes_per_min": round(len(seeds) / minutes, 2), "expert_success": successes / len(seeds),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", nargs="+", default=["bimanual"], help="task names or all / bimanual / unimanual")
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--label", default="after", help="which side of a change these rows measure")
    parser.add_argument("--prior", default="peract_suite", help="the frozen prior timed as the policy ('' skips)")
    parser.add_argument("--out", default="results/sim_profile.json")
    parser.add_argument("--notes", default="")
    args = parser.parse_args()
    started = time.time()
    seeds = split_seeds("test", args.episodes)
    policy = None
    if args.prior:
        import torch

        from bimanualshift.encoders.text import default_text_encoder
        from bimanualshift.methods.frozen_prior import FrozenPriorPerArm

        torch.set_num_threads(2)
        policy = FrozenPriorPerArm.from_pretrained(args.prior, default_text_encoder())
    rows = []
    for task in tqdm(resolve_task_names(args.task), desc="profile", unit="task"):
        row = {"label": args.label, "commit": git_commit(), **profile_task(task, seeds, policy)}
        print(json.dumps(row))
        rows.append(row)
    out = Path(args.out)
    old = json.loads(out.read_text()) if out.is_file() else {}
    kept = [r for r in old.get("rows", []) if r.get("label") != args.label]
    prior = args.prior or "''"
    command = (f"python benchmarks/sim_profile.py --task {' '.join(args.task)} --episodes {args.episodes} "
               f"--label {args.label} --prior {prior}")
    commands = {**old.get("commands", {}), args.label: command}
    notes = {**old.get("notes_by_label", {}), **({args.label: args.notes} if args.notes else {})}
    atomic_write_json(out, {
        "command": command, "commands": commands, "commit": git_commit(), "created": time.strftime(
            "%Y-%m-%dT%H:%M:%S+00:00", time.gmtime()), "machine": machine(),
        "seeds": {"test": seeds}, "wall_time_s": round(time.time() - started, 1), "rows": kept + rows,
        "notes": "one process, one thread of physics; times are means over every control step / keyframe of the "
                 "expert episodes; physics_ms replays the same step's substeps on a copy of its state; policy_ms "
                 "is the median of up to 6 calls of the frozen prior per arm (both arms, no projection)",
        "notes_by_label": notes,
    })
    print(f"wrote {out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
