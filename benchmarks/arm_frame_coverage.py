"""Arm-frame coverage of the single-arm pretraining data (writes results/arm_frame_coverage.json).

    .venv/bin/python benchmarks/arm_frame_coverage.py --episodes 100

For every bimanual task, goal object and arm: the object's x, y and yaw in that arm's base frame over
``--episodes`` train seeds, the same object's range in its single-arm task over as many seeds, and the share of
the bimanual poses inside the single-arm box (yaw counted for oriented objects; buttons, rope ends and the ball
by position). A share below 1 is where the frozen prior sees a layout it never saw in pretraining.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import asdict

from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.report import write_result
from bimanualshift.sim.coverage import SKILL_PAIRS, coverage


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--out", default="results/arm_frame_coverage.json")
    args = parser.parse_args()
    started = time.time()
    seeds = split_seeds("train", args.episodes)
    rows = []
    for task in SKILL_PAIRS:
        for row in coverage(task, seeds, seeds):
            rows.append(asdict(row))
            print(f"{row.task:24s} {row.obj:9s} {row.arm:6s} x {row.bimanual_range[0]} y {row.bimanual_range[1]} "
                  f"yaw {row.bimanual_range[2]} | {row.single_arm_task or '-':28s} "
                  f"{row.single_arm_range} inside {row.inside}")
    write_result(args.out, f"python benchmarks/arm_frame_coverage.py --episodes {args.episodes}",
                 {"train": seeds}, started, rows,
                 notes="arm base frames: bimanual bases at world y = +-0.3, the single-arm base at y = 0; x, y in "
                       "metres and yaw in radians of each goal object's root body (rope: its two ends) after "
                       "initialize_episode; inside = share of bimanual poses within the single-arm poses' "
                       "per-axis range (x, y, and yaw for oriented objects)")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
