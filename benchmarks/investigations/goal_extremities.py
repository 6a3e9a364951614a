"""How close the goal geometry's cues lie to each arm's first expert keyframe (writes results/goal_extremities.json)

    .venv/bin/python benchmarks/investigations/goal_extremities.py --data data/bench/train \
        --tasks straighten_rope sweep_to_dustpan

For every demo of each task, both arms: the horizontal distance from the expert's keyframe-0 position to the goal
box's centroid and to the tip of the arm's own extremity (``perception/goal_geometry.py``), both in the arm's frame
and from the same projection and segmentation training uses. Nothing is trained or rolled out.
"""

from __future__ import annotations

import time

import numpy as np
from demo_goals import demo_arguments, goal_builder, task_demos
from tqdm import tqdm

from bimanualshift.data.episode import read_episode
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.perception.goal_geometry import BOX_GEOMETRY_DIM
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def summary(name: str, errors: list[float]) -> dict[str, float]:
    """Flat columns (the results tables show scalars): median, share within 2 cm, 90th percentile."""
    e = np.asarray(errors)
    return {f"{name}_median_cm": round(float(np.median(e)), 2),
            f"{name}_within_2cm": round(float(np.mean(e <= 2.0)), 3),
            f"{name}_p90_cm": round(float(np.percentile(e, 90)), 2)}


def main() -> None:
    args = demo_arguments(__doc__, "results/goal_extremities.json")
    started = time.time()
    builder = goal_builder()
    rows, seeds = [], {}
    for task in args.tasks:
        paths = task_demos(args.data, task)
        centroid, tip = [], []
        for path in tqdm(paths, desc=task, unit="ep"):
            episode = read_episode(path)
            seeds.setdefault(task, []).append(int(episode.seed))
            obs = KeyframeObservation.from_episode(episode, 0)
            per_arm = builder.build(obs)
            for i, arm in enumerate(episode.arm_names):
                frame = ArmFrame(tuple(episode.arm_bases[arm]))
                action = episode["actions"][0, i]
                target, _ = frame.pose_to_arm(action[:3], action[3:7])
                goal = per_arm[arm].goal
                centroid.append(100 * float(np.linalg.norm(goal[:2] - target[:2])))
                tip.append(100 * float(np.linalg.norm(goal[BOX_GEOMETRY_DIM:BOX_GEOMETRY_DIM + 2] - target[:2])))
        rows.append({"task": task, "arms": len(tip), **summary("centroid", centroid), **summary("own_tip", tip)})
        print(f"{task}: expert's first keyframe from the box centroid {rows[-1]['centroid_median_cm']} cm, from "
              f"the arm's own tip {rows[-1]['own_tip_median_cm']} cm (median of {len(tip)} arms)")
    command = invoked_command()
    write_result(args.out, command, seeds, started, rows,
                 notes="keyframe 0 of every demo, both arms; horizontal distances in cm in the arm's frame "
                       "(within_2cm: the share of arms)")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
