"""Demonstration collection speed with 1 and 2 worker processes (writes results/collection_speed.json).

    .venv/bin/python benchmarks/collection_speed.py --task lift_ball --episodes 16

Collects the same training seeds into a fresh temporary folder once per worker count (rendering the six
cameras at every keyframe and writing HDF5, as `bimanualshift collect` does) and reports episodes per minute.
Worker start-up (spawn + building the scene) is included: it is part of what a user waits for.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from bimanualshift.data.collect import collect
from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.report import write_result
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="lift_ball")
    parser.add_argument("--episodes", type=int, default=16)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--image-size", type=int, default=128)
    parser.add_argument("--out", default="results/collection_speed.json")
    args = parser.parse_args()

    seeds = split_seeds("train", args.episodes)
    started = time.time()
    rows = []
    for workers in args.workers:
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            stats = collect([args.task], seeds, Path(tmp), workers=workers, image_size=args.image_size)
            seconds = time.perf_counter() - t0
        rows.append({
            "task": args.task, "workers": workers, "episodes": args.episodes,
            "succeeded": stats[args.task]["succeeded"], "seconds": round(seconds, 1),
            "episodes_per_min": round(60 * args.episodes / seconds, 2), "image_size": args.image_size,
        })
        print(f"{workers} worker(s): {rows[-1]['episodes_per_min']} episodes/min ({seconds:.0f} s)")
    command = "python benchmarks/collection_speed.py " + " ".join(
        [f"--task {args.task}", f"--episodes {args.episodes}", "--workers", *map(str, args.workers)])
    write_result(args.out, command, {"train": seeds}, started, rows,
                 notes="expert demos rendered at every keyframe (6 cameras: RGB, depth, segmentation) and written "
                       "to HDF5; episodes per minute include starting the worker processes")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
