"""Why single-arm success is what it is: each prior's per-keyframe error on the validation demos, per task
(writes results/prior_keyframe_errors.json).

    .venv/bin/python benchmarks/investigations/prior_keyframe_errors.py --prior peract_suite dp_suite \
        --data data/suite_val

A rollout succeeds only if every keyframe lands close enough, so per-keyframe translation error (and how often it
stays within 2 / 3 cm) and rotation error (and how often within 15 degrees), teacher-forced on expert
observations, show which part of the prediction limits a task.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
import torch
from tqdm import tqdm

from bimanualshift.data.episode import list_episodes
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.arm_samples import build_arm_samples
from bimanualshift.perception.observation import ArmObservationBuilder
from bimanualshift.priors import UnimanualPrior
from bimanualshift.sim.task_registry import resolve_task_names
from bimanualshift.training.keyframe_errors import keyframe_errors
from bimanualshift.training.pretrain import PriorBatches
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--prior", nargs="+", default=["peract_suite", "dp_suite"])
    parser.add_argument("--tasks", nargs="+", default=["unimanual"])
    parser.add_argument("--data", default="data/suite_val", help="validation demos (one sub-folder per task)")
    parser.add_argument("--out", default="results/prior_keyframe_errors.json")
    args = parser.parse_args()
    torch.set_num_threads(2)
    started = time.time()
    rows, seeds = [], set()
    tasks = resolve_task_names(args.tasks)
    for name in args.prior:
        model = UnimanualPrior.from_pretrained(name).freeze()
        grid = VoxelGrid(tuple(model.config.bounds), model.config.voxel_size)
        builder = ArmObservationBuilder(grid, points=model.cloud_points)
        for task in tqdm(tasks, desc=f"keyframe errors {name}"):
            paths = list_episodes(args.data, task)
            if not paths:
                sys.exit(f"no validation demos for {task} under {args.data}; collect them with "
                         f"`bimanualshift collect --task {task} --split validation --out {args.data}`")
            seeds |= {int(p.stem.rsplit("_", 1)[1]) for p in paths}  # episode_<seed>.h5
            samples = build_arm_samples(paths, builder, model.config.max_keyframes, desc=None)
            trans, rot, coarse = keyframe_errors(model, PriorBatches(samples, grid, model.action_horizon))
            stage_one = {} if coarse is None else {
                "median_translation_cm_stage1": round(100 * float(np.median(coarse)), 2)}
            rows.append({"prior": name, "task": task, "episodes": len(paths), "keyframes": len(trans),
                         **stage_one, "median_translation_cm": round(100 * float(np.median(trans)), 2),
                         "within_2cm": round(float(np.mean(trans < 0.02)), 3),
                         "within_3cm": round(float(np.mean(trans < 0.03)), 3),
                         "median_rotation_deg": round(float(np.median(rot)), 1),
                         "within_15deg": round(float(np.mean(rot < 15)), 3)})
    command = invoked_command()
    notes = (f"teacher-forced on the expert's observations of the validation demos in {args.data}; "
             "the voxel of the 32^3 grid is 2.2 x 2.8 x 1.6 cm")
    path = write_result(args.out, command, {"validation": sorted(seeds)}, started, rows, notes=notes)
    for r in rows:
        print(r)
    print(f"wrote {path}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
