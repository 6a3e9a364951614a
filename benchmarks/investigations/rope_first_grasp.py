"""Where each method's first grasp lands on the rope (writes results/rope_first_grasp.json)

    .venv/bin/python benchmarks/investigations/rope_first_grasp.py --folder results/table1/complex_tasks

Reads a bench folder's per-keyframe log of straighten rope and, for every test episode, rebuilds the scene of
its seed to measure each arm's first executed action (keyframe 0, the approach above the grasp): its horizontal
distance to the expert's grasp, to the nearest rope segment, and which end it chose (its position along the rope,
0 at the head and 1 at the tail, against the expert's). Nothing is rolled out.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from bimanualshift.evaluation.bench import KEYFRAME_LOG
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.props.rope import rope_bodies
from bimanualshift.utils.jsonl import read_records
from bimanualshift.utils.pipes import quiet_on_closed_pipe

TASK = "straighten_rope"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--folder", default="results/table1/complex_tasks", help="a bench folder with keyframes.jsonl")
    parser.add_argument("--methods", nargs="*", default=[], help="only these methods (default: every one logged)")
    parser.add_argument("--out", default="results/rope_first_grasp.json")
    args = parser.parse_args()
    started = time.time()
    logs = [r for r in read_records(Path(args.folder) / KEYFRAME_LOG)
            if r["task"] == TASK and (not args.methods or r["method"] in args.methods)]
    if not logs:
        sys.exit(f"error: no logged {TASK} episodes in {args.folder}/{KEYFRAME_LOG}")
    seeds = sorted({r["seed"] for r in logs})
    env = ManipulationEnv(TASK)
    rope = {}  # seed -> (segments, head-to-tail) xy of the rope's segment origins at the start
    for seed in seeds:
        env.reset(seed=seed)
        rope[seed] = np.array([env.sim.data.xpos[env.sim.body_id(b)][:2] for b in rope_bodies("rope")])
    env.close()
    rows = []
    for method in dict.fromkeys(r["method"] for r in logs):
        errors, off_rope, along, residual = [], [], [], []
        for r in (x for x in logs if x["method"] == method):
            first = r["steps"][0]
            segments = rope[r["seed"]]
            # how far the residual moved each arm's first action from the prior's (residual methods only)
            residual += [a["residual_cm"] for a in (first.get("policy") or {}).get("arms", []) if "residual_cm" in a]
            for executed, expert in zip(first["executed"], first["expert"]):
                mine, theirs = np.asarray(executed[:2]), np.asarray(expert[:2])
                errors.append(100 * np.linalg.norm(mine - theirs))
                off_rope.append(100 * np.linalg.norm(segments - mine, axis=1).min())
                position = [np.argmin(np.linalg.norm(segments - p, axis=1)) / (len(segments) - 1)
                            for p in (mine, theirs)]
                along.append(abs(position[0] - position[1]))
        rows.append({"method": method, "arms": len(errors),
                     "grasp_error_cm_median": round(float(np.median(errors)), 2),
                     "within_2cm": round(float(np.mean(np.asarray(errors) <= 2.0)), 3),
                     "off_rope_cm_median": round(float(np.median(off_rope)), 2),
                     "along_rope_gap_median": round(float(np.median(along)), 3),
                     "same_end": round(float(np.mean(np.asarray(along) < 0.5)), 3),
                     "residual_cm_max": round(float(np.max(residual)), 2) if residual else None,
                     "residual_cm_median": round(float(np.median(residual)), 2) if residual else None})
    for row in rows:
        print(f"{row['method']:22s} first grasp {row['grasp_error_cm_median']:5.1f} cm from the expert's (median), "
              f"{100 * row['within_2cm']:3.0f} % within 2 cm, {row['off_rope_cm_median']:4.1f} cm off the rope, "
              f"same end {100 * row['same_end']:.0f} %"
              + ("" if row["residual_cm_max"] is None else f", residual {row['residual_cm_median']} cm median, "
                 f"{row['residual_cm_max']} cm max"))
    command = invoked_command()
    write_result(args.out, command, {"test": seeds}, started, rows,
                 notes="keyframe 0 of every logged test episode, both arms; horizontal distances in cm; rope "
                       "segments are their body origins at the start of the episode; 'along' is the gap between the "
                       "policy's and the expert's nearest segment as a share of the rope's length")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
