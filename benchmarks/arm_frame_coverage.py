"""Arm-frame coverage of the single-arm pretraining data (writes results/arm_frame_coverage.json).

    .venv/bin/python benchmarks/arm_frame_coverage.py --episodes 100

For every bimanual task, kind of goal object and arm (the objects that arm acts on, ``Task.arm_goals``): their
x, y and yaw in that arm's base frame over ``--episodes`` test seeds, the same kind's poses in its single-arm task
over ``--single-arm-episodes`` train seeds (the pretraining data), and the share of the bimanual poses with a
single-arm sample within 5 cm (and 0.2 rad for oriented objects; buttons, plates, rope ends and the ball by
position). A share below 1 is where the frozen prior sees a layout it never saw in pretraining.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import asdict

from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.report import write_result
from bimanualshift.sim.coverage import SKILL_PAIRS, coverage
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--single-arm-episodes", type=int, default=600)
    parser.add_argument("--out", default="results/arm_frame_coverage.json")
    args = parser.parse_args()
    started = time.time()
    seeds = split_seeds("test", args.episodes)
    single_arm_seeds = split_seeds("train", args.single_arm_episodes)
    rows = []
    for task in SKILL_PAIRS:
        for row in coverage(task, seeds, single_arm_seeds):
            rows.append(asdict(row))
            print(f"{row.task:24s} {row.obj:9s} {row.arm:6s} x {row.bimanual_range[0]} y {row.bimanual_range[1]} "
                  f"yaw {row.bimanual_range[2]} | {row.single_arm_task or '-':28s} "
                  f"{row.single_arm_range} inside {row.inside} worst gap {row.farthest_cm} cm")
    command = (f"python benchmarks/arm_frame_coverage.py --episodes {args.episodes} "
               f"--single-arm-episodes {args.single_arm_episodes}")
    write_result(args.out, command, {"test": seeds, "train": single_arm_seeds}, started, rows,
                 notes="arm base frames: bimanual bases at world y = +-0.3, the single-arm base at y = 0; x, y in "
                       "metres and yaw in radians of the root body of each object the arm acts on (rope: the end "
                       "it takes) after initialize_episode, bimanual on test seeds, single-arm on train seeds; "
                       "inside = share of bimanual poses with a single-arm sample within 5 cm (and 0.2 rad for "
                       "oriented objects); worst gap = the largest distance from a bimanual pose to its nearest "
                       "single-arm sample")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
