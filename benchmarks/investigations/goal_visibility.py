"""How much of each goal object the cameras see, per keyframe of the demos (writes results/goal_visibility.json)

    .venv/bin/python benchmarks/investigations/goal_visibility.py \
        --tasks take_tray_out_of_oven sweep_to_dustpan straighten_rope \
        --demos 10

The Manager locates the goal from the pixels the segmenter gives for each goal noun (``perception/goal_geometry.py``).
An object hidden at a keyframe (the tray behind the shut oven door, dirt under the brush) cannot be located there.
Per task, goal noun and keyframe: the median, over the first ``--demos`` training demos, of that noun's pixels
summed over every camera, as the simulator's segmenter (the benchmark's) gives them. Nothing is rolled out.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from tqdm import tqdm

from bimanualshift.data.episode import list_episodes, read_episode
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.perception.segmenters.base import CameraView
from bimanualshift.perception.segmenters.simulator import SimulatorSegmenter
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def goal_pixels(obs: KeyframeObservation, segmenter: SimulatorSegmenter) -> dict[str, int]:
    """Each goal noun's pixels at one keyframe, summed over the cameras."""
    scene = obs.scene
    colours = [scene.instance_colours.get(n, []) for n in scene.instance_names] if scene.instance_colours else None
    counts = dict.fromkeys(scene.goal_nouns, 0)
    for c in range(len(obs.depth)):
        view = CameraView(obs.rgb[c], obs.instance[c], obs.class_ids[c], scene.class_names, colours)
        for detection in segmenter.segment(view, list(scene.goal_nouns)):
            counts[detection.label] += int(detection.mask.sum())
    return counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", required=True)
    parser.add_argument("--demos", type=int, default=10, help="training demos per task (the first ones)")
    parser.add_argument("--data", default="data/bench/train", help="the demos' folder")
    parser.add_argument("--out", default="results/goal_visibility.json")
    args = parser.parse_args()
    started = time.time()
    segmenter = SimulatorSegmenter()
    rows, seeds = [], {}
    for task in args.tasks:
        paths = list_episodes(args.data, task)[: args.demos]
        if not paths:
            sys.exit(f"error: no demos of {task} under {args.data}: run `bimanualshift collect --task {task} "
                     f"--out {args.data}` first")
        per_keyframe: dict[tuple[str, int], list[int]] = {}
        seeds[task] = []
        for path in tqdm(paths, desc=task, unit="demo"):
            episode = read_episode(path)
            seeds[task].append(int(episode.seed))
            for k in range(episode.num_keyframes):
                for noun, pixels in goal_pixels(KeyframeObservation.from_episode(episode, k), segmenter).items():
                    per_keyframe.setdefault((noun, k), []).append(pixels)
        for (noun, k), counts in sorted(per_keyframe.items(), key=lambda item: (item[0][0], item[0][1])):
            rows.append({"task": task, "goal_noun": noun, "keyframe": k, "demos": len(counts),
                         "median_pixels": int(np.median(counts)), "min_pixels": int(min(counts)),
                         "max_pixels": int(max(counts))})
    for task in args.tasks:
        print(task)
        for noun in dict.fromkeys(r["goal_noun"] for r in rows if r["task"] == task):
            line = " ".join(str(r["median_pixels"]) for r in rows if r["task"] == task and r["goal_noun"] == noun)
            print(f"  {noun:>16}: {line}")
    command = invoked_command()
    write_result(args.out, command, seeds, started, rows,
                 notes="per task, goal noun and keyframe: median / min / max over the demos of the noun's pixels "
                       "summed over every camera (simulator segmenter), at keyframe k's observation")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
