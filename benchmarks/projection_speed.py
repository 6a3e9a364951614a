"""Milliseconds to project six 128x128 RGB-D frames into both arms' voxel masks (writes
results/projection_speed.json).

    .venv/bin/python benchmarks/projection_speed.py --task push_two_buttons --repeats 50

Times ``ArmObservationBuilder.build`` with the arm-conditioned projection and the simulator segmenter on
real keyframes of the scripted expert (segmentation, nearest-anchor assignment, back-projection and
voxelisation of both arms), against the same build without the projection.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from bimanualshift.data.frames import KeyframeObservation, scene_of_env
from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.report import write_result
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.observation import DEFAULT_ARM_BOUNDS, ArmObservationBuilder
from bimanualshift.perception.projection import ArmProjection
from bimanualshift.perception.segmenters import make_segmenter
from bimanualshift.sim.env import ManipulationEnv


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="push_two_buttons")
    parser.add_argument("--repeats", type=int, default=50)
    parser.add_argument("--voxels", type=int, default=32)
    parser.add_argument("--out", default="results/projection_speed.json")
    args = parser.parse_args()

    seed = split_seeds("test", 1)[0]
    env = ManipulationEnv(args.task, image_size=128)
    obs, _ = env.reset(seed=seed)
    scene = scene_of_env(env)
    frames = [KeyframeObservation.from_env(obs, scene)]
    for keyframe in env.expert_keyframes():
        obs, *_ = env.step(env.action_from_keyframe(keyframe))
        frames.append(KeyframeObservation.from_env(obs, scene))
    env.close()
    grid = VoxelGrid(DEFAULT_ARM_BOUNDS, args.voxels)
    started = time.time()
    rows = []
    for name, builder in (("projection (both arms)", ArmObservationBuilder(grid, ArmProjection(make_segmenter(
            "simulator")))), ("no projection (both arms)", ArmObservationBuilder(grid))):
        times = []
        for _ in range(args.repeats):
            for frame in frames:
                t0 = time.perf_counter()
                builder.build(frame)
                times.append(1000 * (time.perf_counter() - t0))
        rows.append({"task": args.task, "what": name, "cameras": len(scene.camera_names), "image_size": 128,
                     "voxels": args.voxels, "ms_per_keyframe_median": round(float(np.median(times)), 2),
                     "ms_per_keyframe_p90": round(float(np.percentile(times, 90)), 2), "calls": len(times)})
        print(f"{name}: median {rows[-1]['ms_per_keyframe_median']} ms, p90 {rows[-1]['ms_per_keyframe_p90']} ms")
    projection_only = rows[0]["ms_per_keyframe_median"] - rows[1]["ms_per_keyframe_median"]
    write_result(args.out, f"python benchmarks/projection_speed.py --task {args.task} --repeats {args.repeats}",
                 {"test": [seed]}, started, rows,
                 notes=f"one process on this CPU; the projection itself adds {projection_only:.1f} ms per keyframe "
                       "(median difference) to building both arms' voxel observations")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
