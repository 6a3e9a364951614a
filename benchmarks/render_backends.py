"""EGL against OSMesa: one six-camera RGB-D + segmentation observation each (writes results/render_backends.json).

    .venv/bin/python benchmarks/render_backends.py

Each backend runs in its own process (MuJoCo picks its GL backend from ``MUJOCO_GL`` at import). OSMesa needs
Debian's ``libosmesa6``; a backend that cannot start is reported as unavailable with its error, not skipped
silently.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.report import write_result
from bimanualshift.utils.pipes import quiet_on_closed_pipe

CHILD = """
import json, statistics, sys, time
from bimanualshift.sim.env import ManipulationEnv
env = ManipulationEnv(sys.argv[1])
times = []
for seed in json.loads(sys.argv[2]):
    env.reset(seed=seed, options={"render": False})
    env.observe()  # warm-up of this scene
    t0 = time.perf_counter()
    for _ in range(5):
        env.observe()
    times.append(1000 * (time.perf_counter() - t0) / 5)
print(json.dumps({"observation_ms": round(statistics.median(times), 1), "cameras": len(env.camera_names)}))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="push_two_buttons")
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument("--out", default="results/render_backends.json")
    args = parser.parse_args()
    started = time.time()
    seeds = split_seeds("test", args.episodes)
    rows = []
    for backend in ("egl", "osmesa"):
        env = {**os.environ, "MUJOCO_GL": backend, "PYOPENGL_PLATFORM": backend}
        done = subprocess.run([sys.executable, "-c", CHILD, args.task, json.dumps(seeds)], env=env,
                              capture_output=True, text=True)
        row = {"backend": backend, "task": args.task}
        if done.returncode == 0:
            row.update(json.loads(done.stdout.strip().splitlines()[-1]))
        else:
            row.update({"observation_ms": None, "error": done.stderr.strip().splitlines()[-1][:300]})
        print(row)
        rows.append(row)
    write_result(args.out, f"python benchmarks/render_backends.py --task {args.task} --episodes {args.episodes}",
                 {"test": seeds}, started, rows,
                 notes="median over seeds of the mean of 5 observations (every camera: colour pass, segmentation "
                       "pass with depth); one process per backend; Mesa's software rasterisers on 2 CPU cores")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
