"""A folder of episodes through LeRobot v3.0 and back, compared array by array (writes a result file)

    .venv/bin/python benchmarks/lerobot_round_trip.py data/realworld/train --out results/lerobot_round_trip_ur5e.json

Exports every task folder under DATA as one dataset (`bimanualshift export-lerobot`'s writer and robot type),
imports it back (`import-lerobot`'s reader) and compares each episode with its source: depth, segmentation,
calibration, state, actions and the dense trajectory must come back bit for bit; RGB goes through AV1 video (as
LeRobot stores it), so its PSNR is reported. Nothing is rolled out.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from bimanualshift.cli.deploy import robot_type_of
from bimanualshift.data.episode import read_episode
from bimanualshift.data.lerobot_format import export_lerobot, import_lerobot
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.utils.pipes import quiet_on_closed_pipe

EXACT = ("depth", "instance", "class", "intrinsics", "extrinsics", "proprio", "actions")


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10(255**2 / mse)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("data", help="a folder of episodes, a sub-folder per task (`collect`, `record`)")
    parser.add_argument("--out", required=True, help="the result file to write")
    parser.add_argument("--dataset", default="", help="keep the exported dataset here (default: a temporary folder)")
    args = parser.parse_args()
    started = time.time()
    root = Path(args.data)
    tasks = sorted(p.name for p in root.iterdir() if p.is_dir() and any(p.glob("episode_*.h5")))
    if not tasks:
        raise SystemExit(f"error: no task folders with episode_*.h5 files under {root}")
    paths = [p for t in tasks for p in sorted((root / t).glob("episode_*.h5"))]
    episodes = [read_episode(p) for p in paths]
    with tempfile.TemporaryDirectory() as tmp:
        target = Path(args.dataset or Path(tmp) / "dataset")
        t0 = time.time()
        out = export_lerobot(episodes, target, robot_type_of(tasks), overwrite=True)
        export_s = time.time() - t0
        size_mb = sum(f.stat().st_size for f in out.rglob("*") if f.is_file()) / 1e6
        t0 = time.time()
        back = import_lerobot(out)
        import_s = time.time() - t0
    if len(back) != len(episodes):
        raise SystemExit(f"error: {len(episodes)} episodes exported, {len(back)} read back")
    rows = []
    for task in tasks:
        pairs = [(a, b) for a, b in zip(episodes, back) if a.task == task]
        exact = all(np.array_equal(a.arrays[k], b.arrays[k]) and a.arrays[k].dtype == b.arrays[k].dtype
                    for a, b in pairs for k in EXACT if k in a.arrays)
        dense = all(a.dense is None or all(np.array_equal(a.dense[k], b.dense[k]) for k in a.dense) for a, b in pairs)
        meta = all((a.task, a.seed, a.instruction, a.arm_bases, a.goal_nouns, a.camera_names)
                   == (b.task, b.seed, b.instruction, b.arm_bases, b.goal_nouns, b.camera_names) for a, b in pairs)
        rgb = [psnr(a.arrays["rgb"], b.arrays["rgb"]) for a, b in pairs]
        rows.append({"task": task, "episodes": len(pairs), "keyframes": sum(a.num_keyframes for a, _ in pairs),
                     "cameras": len(pairs[0][0].camera_names), "image_size": int(pairs[0][0].arrays["rgb"].shape[-2]),
                     "exact_arrays": exact, "exact_dense": dense, "exact_metadata": meta,
                     "rgb_psnr_db_min": round(min(rgb), 1), "rgb_psnr_db_mean": round(float(np.mean(rgb)), 1)})
        print(f"{task:24s} {len(pairs):3d} episodes  exact {exact and dense and meta}  RGB PSNR min {min(rgb):.1f} dB")
    seeds = sorted({e.seed for e in episodes})
    write_result(args.out, invoked_command(), {"train": [seeds[0], seeds[-1]]}, started, rows,
                 notes=f"{len(episodes)} episodes of {root} exported as one LeRobot v3.0 dataset (robot_type "
                       f"{robot_type_of(tasks)}, {size_mb:.1f} MB, {export_s:.0f} s) and read back ({import_s:.0f} s); "
                       "exact_*: every array, the dense trajectory and the episode metadata equal to the source; RGB "
                       "through AV1 video at crf 30, LeRobot's setting")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
