"""Milliseconds to project six 128x128 RGB-D frames into both arms' voxel masks (writes
results/projection_speed.json).

    .venv/bin/python benchmarks/projection_speed.py --task bimanual --repeats 20

For every keyframe of one scripted-expert episode per task, times (one process, after a warm-up that compiles
the numba kernels):

* ``voxel masks (both arms)``: ``ArmProjection.voxel_masks`` with the simulator segmenter -- segmentation,
  nearest-anchor assignment (Eq. 2), union with the goal (Eq. 3) and back-projection of both arms' kept pixels
  into their arm-frame voxel grids (M_3D of Eq. 1). This is the number the target (<= 5 ms) is about.
* ``observation with projection``: ``ArmObservationBuilder.build`` -- both arms' full observations V * M_3D
  (voxel occupancy and colour plus proprioception), and the same build without the projection for comparison.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np
from tqdm import tqdm

from bimanualshift.data.frames import KeyframeObservation, scene_of_env
from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.report import write_result
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.observation import DEFAULT_ARM_BOUNDS, ArmObservationBuilder, arm_frames
from bimanualshift.perception.projection import ArmProjection
from bimanualshift.perception.segmenters import make_segmenter
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.task_registry import task_names
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def expert_frames(task: str, seed: int, image_size: int) -> list[KeyframeObservation]:
    env = ManipulationEnv(task, image_size=image_size)
    obs, _ = env.reset(seed=seed)
    scene = scene_of_env(env)
    frames = [KeyframeObservation.from_env(obs, scene)]
    for keyframe in env.expert_keyframes():
        obs, *_ = env.step(env.action_from_keyframe(keyframe))
        frames.append(KeyframeObservation.from_env(obs, scene))
    env.close()
    return frames


def time_calls(fn: Callable[[KeyframeObservation], object], frames: list[KeyframeObservation], repeats: int
               ) -> list[float]:
    fn(frames[0])  # warm-up: numba compilation and ray caches
    times = []
    for _ in range(repeats):
        for frame in frames:
            t0 = time.perf_counter()
            fn(frame)
            times.append(1000 * (time.perf_counter() - t0))
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="bimanual", help="a task name or 'bimanual' for all six")
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--voxels", type=int, nargs="+", default=[32, 100])
    parser.add_argument("--image-size", type=int, default=128)
    parser.add_argument("--out", default="results/projection_speed.json")
    args = parser.parse_args()

    tasks = task_names(bimanual=True) if args.task == "bimanual" else [args.task]
    seed = split_seeds("test", 1)[0]
    started = time.time()
    rows = []
    for task in tqdm(tasks, desc="projection speed", unit="task"):
        frames = expert_frames(task, seed, args.image_size)
        transforms = {arm: f.world_to_base for arm, f in arm_frames(frames[0]).items()}
        for size in args.voxels:
            grid = VoxelGrid(DEFAULT_ARM_BOUNDS, size)
            projection = ArmProjection(make_segmenter("simulator"))
            cases = {
                "voxel masks (both arms)": lambda f, p=projection, g=grid, t=transforms: p.voxel_masks(f, g, t),
                "observation with projection (both arms)": ArmObservationBuilder(grid, projection).build,
                "observation without projection (both arms)": ArmObservationBuilder(grid).build,
            }
            for what, fn in cases.items():
                times = time_calls(fn, frames, args.repeats)
                rows.append({"task": task, "what": what, "cameras": len(frames[0].scene.camera_names),
                             "image_size": args.image_size, "voxels": size,
                             "ms_median": round(float(np.median(times)), 2),
                             "ms_p90": round(float(np.percentile(times, 90)), 2), "calls": len(times)})
    print(f"{'task':24} {'what':44} {'voxels':>6} {'median ms':>10} {'p90 ms':>8}")
    for r in rows:
        print(f"{r['task']:24} {r['what']:44} {r['voxels']:>6} {r['ms_median']:>10} {r['ms_p90']:>8}")
    masks = [r["ms_median"] for r in rows if r["what"].startswith("voxel masks") and r["voxels"] == args.voxels[0]]
    voxel_list = " ".join(map(str, args.voxels))
    write_result(args.out, f"python benchmarks/projection_speed.py --task {args.task} --repeats {args.repeats} "
                 f"--voxels {voxel_list} --image-size {args.image_size}", {"test": [seed]}, started, rows,
                 notes=f"one process, every keyframe of one expert episode per task; voxel masks of both arms at "
                       f"{args.voxels[0]}^3: {min(masks):.2f}-{max(masks):.2f} ms median over tasks (target <= 5 ms)")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
