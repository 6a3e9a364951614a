"""How well a trained residual turns the prior's orientation into the expert's, on its own training demos and on
the validation demos, per arm and keyframe (writes results/rotation_fit/<task>.json)

    .venv/bin/python benchmarks/investigations/rotation_fit.py runs/table1/sweep_to_dustpan/bimanualshift

Teacher-forced: every keyframe of the demos is given to the frozen prior and the residual as the demo saw it, and
the angle left between prior + residual and the expert is measured (``validation_rotation_error`` of the training
summary, here on both splits and without augmentation). A small error on the training demos and a large one on
the validation demos is a residual that fits what it saw and does not generalise; large on both is one that never
learnt the turn; small on both, with large turns in closed loop, is states the demos never showed. Per keyframe it
also gives the share of targets that turn counter-clockwise about the vertical: near 0 or 1 the demos ask one way,
near a half two ways (a grasp whose two half-turn twins lie equally far from the prior's proposal). Reads the run's
``train_config.json`` for its demos and loads its ``best`` checkpoint (the run before refinement). Nothing is
rolled out.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from bimanualshift.data.episode import list_episodes
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.methods.bimanualshift import load_bimanualshift
from bimanualshift.residual.manager import arm_and_slot
from bimanualshift.training.residual_data import residual_data
from bimanualshift.training.residual_losses import rotation_report
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", help="a residual run folder holding train_config.json and best/")
    parser.add_argument("--out", default="", help="result file (default: results/rotation_fit/<task>.json)")
    args = parser.parse_args()
    run = Path(args.run)
    if not (run / "train_config.json").is_file() or not (run / "best" / "config.json").is_file():
        raise SystemExit(f"{run} is not a residual run: it needs train_config.json and best/ (from `bimanualshift "
                         "train` or a bench's runs/<task>/<method>)")
    started = time.time()
    cfg = json.loads((run / "train_config.json").read_text())
    task, dataset = cfg["dataset"]["task"], cfg["dataset"]
    policy = load_bimanualshift(run / "best")
    rcfg = policy.residual.config
    splits = {"train": (list_episodes(dataset["data"], task)[: dataset["demos"]], True),
              "validation": (list_episodes(dataset["validation_data"], task), False)}
    rows = []
    for split, (paths, own) in splits.items():
        if not paths:
            raise SystemExit(f"no {split} demos of {task} under {dataset['data' if own else 'validation_data']}: "
                             "collect them again with the bench's seeds (data/ is not committed)")
        data = residual_data(rcfg, paths, policy.prior_step, policy.text_encoder, f"prior outputs ({split})",
                             memory=policy.memory, own_memory=own and policy.memory is not None)
        report = rotation_report(policy.residual, data)
        arms, slots = arm_and_slot(rcfg, data.inputs)
        for arm in sorted(k for k in report if k.startswith("arm_")):
            per, index = report[arm], int(arm.split("_")[1])
            for i, keyframe in enumerate(per["keyframes"]):
                rows_here = (arms == index) & (slots == keyframe)
                rows.append({"split": split, "arm": index, "keyframe": keyframe,
                             "prior_deg": round(float(np.degrees(per["prior_median_rad"][i])), 1),
                             "prior_plus_residual_deg": round(float(np.degrees(
                                 per["prior_plus_residual_median_rad"][i])), 1),
                             "counter_clockwise_share": round(float((data.rotation[rows_here, 2] > 0).float().mean()),
                                                              2)})
        print(f"{split}: prior {np.degrees(report['prior_median_rad']):.1f} deg, prior + residual "
              f"{np.degrees(report['prior_plus_residual_median_rad']):.1f} deg (medians over every arm and keyframe)")
    for row in rows:
        print(f"{row['split']:<10} arm {row['arm']} k{row['keyframe']:<2} prior {row['prior_deg']:6.1f}  "
              f"prior + residual {row['prior_plus_residual_deg']:6.1f}  "
              f"counter-clockwise {row['counter_clockwise_share']}")
    out = args.out or f"results/rotation_fit/{task}.json"
    write_result(out, invoked_command(), {}, started, rows, task=task, run=str(run),
                 notes="teacher-forced on the run's training demos (unaugmented) and validation demos: median angle "
                       "between the expert's orientation and the prior's (prior_deg) or prior + residual's, per arm "
                       "(0 left, 1 right) and keyframe; counter_clockwise_share: the share of its rotation targets "
                       "turning counter-clockwise about the vertical; the run's best/ checkpoint")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
