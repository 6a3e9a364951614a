"""How often the demos' poses come out with the quaternion negated near the gripper-down pose (writes a result file)

    .venv/bin/python benchmarks/investigations/quaternion_signs.py --data data/bench/train \
        --tasks lift_ball straighten_rope

Every keyframe's proprioception of both arms, in the arm's frame as the Manager reads it (w >= 0, the environment's
sign): the share with x < 0, i.e. on the other side of the gripper-down pose (1, 0, 0, 0) than the expert's
targets. ``--quaternion-sign gripper_down`` (docs/residual.md) gives them all on one side.
"""

from __future__ import annotations

import argparse
import sys
import time

from bimanualshift.data.episode import list_episodes, read_episode
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.perception.observation import proprio_in_arm_frame
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default="data/bench/train", help="a folder of bimanual demos (<task>/episode_*.h5)")
    parser.add_argument("--tasks", nargs="+", default=["lift_ball", "straighten_rope"])
    parser.add_argument("--episodes", type=int, default=30, help="the first N demos of each task")
    parser.add_argument("--out", default="results/quaternion_signs.json")
    args = parser.parse_args()
    started = time.time()
    rows, seeds = [], {}
    for task in args.tasks:
        paths = list_episodes(args.data, task)[:args.episodes]
        if not paths:
            sys.exit(f"error: no demos of {task} under {args.data}")
        poses = negated = 0
        for path in paths:
            episode = read_episode(path)
            seeds.setdefault(task, []).append(int(episode.seed))
            for i, arm in enumerate(episode.arm_names):
                frame = ArmFrame(tuple(episode.arm_bases[arm]))
                for pose in episode["proprio"][:, i]:
                    poses += 1
                    negated += int(proprio_in_arm_frame(pose, frame)[3] < 0)
        rows.append({"task": task, "demos": len(paths), "poses": poses, "negated": negated,
                     "negated_share": round(negated / poses, 3)})
        print(f"{task}: {negated} of {poses} poses with x < 0")
    command = invoked_command()
    write_result(args.out, command, seeds, started, rows,
                 notes="keyframe proprioception of both arms in the arm's frame, w >= 0; negated: x < 0")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
