"""How far the two arms may stray from the expert's sweep: the scripted expert with the brush's stroke moved aside,
turned and cut short, and the dustpan's grasp turned (writes results/sweep_tolerance.json)

    .venv/bin/python benchmarks/investigations/sweep_tolerance.py --episodes 30 --across-cm 0 2 3 --turn-deg 0 10 20 \
        --end-short-cm 0 2
    .venv/bin/python benchmarks/investigations/sweep_tolerance.py --episodes 30 --pan-turn-deg 0 20 40 --across-cm 0 2 \
        --out results/sweep_tolerance_pan.json

The expert of sweep to dustpan sets the brush head (16 cm wide) down square behind the dirt, on the pan's centre
line, and strokes into the pan's mouth (20 cm between the side walls). Here its brush arm's keyframes from the
set-down on (the approach above it, the set-down, the stroke's end and the lift) are changed in three ways, alone and
together: moved across the stroke (``--across-cm``, half the episodes to each side), turned about the vertical
(``--turn-deg``, half each way) and the stroke's end pulled back towards its start (``--end-short-cm``, the end and
the lift). ``--pan-turn-deg`` turns every keyframe of the other arm, which pinches the dustpan's handle and holds it,
about the vertical (half each way). Everything else is the expert's. Success per combination says which of the
errors the keyframe logs show the task tolerates (benchmarks/investigations/sweep_stroke.py: BimanualShift's sweep
failures set the brush down a median 2.1 cm aside, 9 degrees turned and end the stroke 1.6 cm short;
``bimanualshift explain``: its dustpan grasp is turned 38 degrees from the expert's in failures against 23 in
successes). Validation seeds; no rendering.
"""

from __future__ import annotations

import argparse
import itertools
import time
from dataclasses import replace
from typing import NamedTuple

import numpy as np
from scipy.spatial.transform import Rotation
from tqdm import tqdm

from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.evaluation.stats import wilson_interval
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.task import Keyframe
from bimanualshift.utils.pipes import quiet_on_closed_pipe

TASK = "sweep_to_dustpan"
ABOVE, END = 4, 6  # the expert's keyframes above the stroke's start and at its end
STROKE = (4, 5, 6, 7)  # the brush arm's keyframes that move aside and turn: above the start, set-down, end, lift
STROKE_END = (6, 7)  # the ones pulled back when the stroke is cut short


class StrokeChange(NamedTuple):
    across_m: float  # positive: to the left of the stroke's direction
    turn_rad: float  # about the vertical, counter-clockwise seen from above
    end_short_m: float  # the stroke's end pulled back towards its start
    pan_turn_rad: float = 0.0  # the dustpan arm's every keyframe turned about the vertical


def change_stroke(keyframes: list[Keyframe], change: StrokeChange, arm: str) -> list[Keyframe]:
    """The expert's keyframes with the brush ``arm``'s stroke changed (the task's roles name it)."""
    stroke = keyframes[END][arm].position[:2] - keyframes[ABOVE][arm].position[:2]
    along = stroke / np.linalg.norm(stroke)
    across = np.array([-along[1], along[0]])
    turn = Rotation.from_euler("z", change.turn_rad)
    pan_arm, pan_turn = next(a for a in keyframes[0] if a != arm), Rotation.from_euler("z", change.pan_turn_rad)
    changed = [dict(k) for k in keyframes]
    for index, keyframe in enumerate(keyframes):
        action = keyframe[pan_arm]
        changed[index][pan_arm] = replace(action, quat=(pan_turn * Rotation.from_quat(action.quat)).as_quat())
    for index in STROKE:
        action = keyframes[index][arm]
        shift = change.across_m * across - (change.end_short_m * along if index in STROKE_END else 0.0)
        changed[index][arm] = replace(action, position=action.position + np.r_[shift, 0.0],
                                      quat=(turn * Rotation.from_quat(action.quat)).as_quat())
    return changed


def run(env: ManipulationEnv, seed: int, change: StrokeChange) -> bool:
    env.reset(seed=seed, options={"render": False})
    _, brush_arm = env.task.roles(env.sim)
    for keyframe in change_stroke(env.expert_keyframes(), change, brush_arm):
        env.step(env.action_from_keyframe(keyframe), render=False)
    return env.success()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=30, help="validation seeds per combination (half each side)")
    parser.add_argument("--across-cm", type=float, nargs="+", default=[0.0])
    parser.add_argument("--turn-deg", type=float, nargs="+", default=[0.0])
    parser.add_argument("--end-short-cm", type=float, nargs="+", default=[0.0])
    parser.add_argument("--pan-turn-deg", type=float, nargs="+", default=[0.0])
    parser.add_argument("--out", default="results/sweep_tolerance.json")
    args = parser.parse_args()
    if args.episodes < 2 or args.episodes % 2:
        raise SystemExit(f"--episodes {args.episodes}: give an even number >= 2 (half the episodes go to each side)")
    started = time.time()
    seeds = split_seeds("validation", args.episodes)
    grid = list(itertools.product(args.across_cm, args.turn_deg, args.end_short_cm, args.pan_turn_deg))
    env = ManipulationEnv(TASK, image_size=64)
    rows = []
    try:
        for across, turn, short, pan_turn in tqdm(grid, desc="stroke changes", unit="change"):
            # the sides alternate by seed, the turns' direction every second seed: all four pairs are tried
            sides = [(1 if i % 2 == 0 else -1, 1 if i // 2 % 2 == 0 else -1) for i in range(len(seeds))]
            wins = [run(env, seed, StrokeChange(side * across / 100, way * np.radians(turn), short / 100,
                                                way * np.radians(pan_turn)))
                    for seed, (side, way) in zip(seeds, sides)]
            low, high = wilson_interval(sum(wins), len(wins))
            rows.append({"across_cm": across, "turn_deg": turn, "end_short_cm": short, "pan_turn_deg": pan_turn,
                         "episodes": len(wins), "success": round(float(np.mean(wins)), 3),
                         "ci95": [round(low, 3), round(high, 3)]})
            print(f"aside {across:4.1f} cm, turned {turn:4.1f} deg, {short:4.1f} cm short, "
                  f"pan turned {pan_turn:4.1f} deg: {sum(wins)}/{len(wins)} successes", flush=True)
    finally:
        env.close()
    write_result(args.out, invoked_command(), {"validation": seeds}, started, rows, task=TASK,
                 notes="the scripted expert with its brush arm's keyframes 4-7 moved across_cm across the stroke "
                       "(sides alternating by seed) and turned turn_deg about the vertical (direction alternating "
                       "every second seed), keyframes 6-7 pulled end_short_cm back along it; the dustpan arm's every "
                       "keyframe turned pan_turn_deg (the same direction as turn_deg); the rest the expert's")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
