"""Where should the VoxAct-B-style baseline centre its region? (writes results/voxactb_region.json)

    .venv/bin/python benchmarks/investigations/voxactb_region.py --demos 5

Per bimanual task, the expert's demos on validation seeds; for each rule that turns the goal's back-projected
pixels at the first keyframe into a centre (their mean, median, or the middle of their 2nd-98th percentile
extent), the share of every keyframe target that falls inside the fixed region around it (``ROI_BOUNDS``). A
target outside the region lands on its edge: the policy cannot reach it.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from bimanualshift.data.collect import record_expert_episode
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.methods.baselines.voxactb import ROI_BOUNDS, ROI_LIFT
from bimanualshift.perception.goal_geometry import goal_world_points
from bimanualshift.perception.projection import ArmProjection
from bimanualshift.perception.segmenters import make_segmenter
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.task_registry import task_names
from bimanualshift.utils.pipes import quiet_on_closed_pipe

RULES: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "mean": lambda p: p.mean(0),
    "median": lambda p: np.median(p, 0),
    "extent_middle": lambda p: np.percentile(p, [2, 98], axis=0).mean(0),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--demos", type=int, default=5, help="expert demos per task (validation seeds)")
    parser.add_argument("--out", default="results/voxactb_region.json")
    args = parser.parse_args()
    started = time.time()
    seeds = split_seeds("validation", args.demos, start=10_000)  # the rollout studies' validation range
    projection = ArmProjection(make_segmenter("simulator"))
    low, high = np.asarray(ROI_BOUNDS[:3]), np.asarray(ROI_BOUNDS[3:])
    rows = []
    for task in task_names(bimanual=True):
        env = ManipulationEnv(task)
        inside: dict[str, list[bool]] = {rule: [] for rule in RULES}
        for seed in seeds:
            episode = record_expert_episode(env, seed)
            obs = KeyframeObservation.from_episode(episode, 0)
            points = goal_world_points(obs, projection.project(obs)[1])
            targets = episode.arrays["actions"][:, :, :3].reshape(-1, 3)
            for rule, centre in RULES.items():
                offset = targets - (centre(points) + np.array([0.0, 0.0, ROI_LIFT]))
                inside[rule] += np.all((offset > low) & (offset < high), axis=1).tolist()
        env.close()
        for rule, flags in inside.items():
            rows.append({"task": task, "rule": rule, "targets": len(flags),
                         "inside": round(100 * float(np.mean(flags)), 1)})
            print(rows[-1])
    command = invoked_command()
    path = write_result(args.out, command, {"validation": seeds}, started, rows,
                        notes=f"region {ROI_BOUNDS} (m, in the frame at its centre), centre {ROI_LIFT} m above the "
                              "rule's point; simulator segmenter; the shipped rule is 'mean'")
    print(f"wrote {path}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
