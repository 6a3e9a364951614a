"""Residual design choices compared on validation demos (writes results/residual_variants.json).

    .venv/bin/python benchmarks/investigations/residual_variants.py --data runs/demo/data/bimanual \
        --validation-data runs/demo/data/bimanual_val --task push_two_buttons --demos 20

Each variant trains the residual with the default settings plus its own flags (the demos, prior and seed shared)
and is scored on the validation demos only, never on test seeds: the pose part of L_BC at the checkpoint
validation picked, and the median translation error and rotation error of prior + residual before the output gate.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.training.configs import TrainConfig
from bimanualshift.training.residual_trainer import train_residual
from bimanualshift.utils.config_files import config_from_flat
from bimanualshift.utils.pipes import quiet_on_closed_pipe

VARIANTS: dict[str, dict] = {
    "default": {},
    "no augmentation": {"augment_copies": 0},
    "yaw 15 deg + shift 4 cm": {"augment_yaw_deg": 15.0, "augment_translation_m": 0.04},
    "yaw 5 deg + shift 2 cm": {"augment_yaw_deg": 5.0, "augment_translation_m": 0.02},
    "paper-literal residual": {"paper_literal": True},
    "no proposal features": {"proposal_features": False},
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="push_two_buttons")
    parser.add_argument("--prior", default="peract_suite")
    parser.add_argument("--data", default="runs/demo/data/bimanual")
    parser.add_argument("--validation-data", default="runs/demo/data/bimanual_val")
    parser.add_argument("--demos", type=int, default=20)
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    parser.add_argument("--runs", default="runs/residual_variants")
    parser.add_argument("--out", default="results/residual_variants.json")
    args = parser.parse_args()
    started = time.time()
    rows = []
    for name in args.variants:
        out = Path(args.runs) / name.replace(" ", "_").replace("+", "").replace("__", "_")
        cfg = config_from_flat(TrainConfig, task=args.task, prior=args.prior, data=args.data,
                               validation_data=args.validation_data, demos=args.demos, out=str(out),
                               **VARIANTS[name])
        if not (out / "summary.json").is_file():
            train_residual(cfg)
        summary = json.loads((out / "summary.json").read_text())
        gate = summary.get("output_gate", {})
        ungated = gate.get("validation_translation_error_ungated") or summary["validation_translation_error"]
        rows.append({"task": args.task, "variant": name, "flags": VARIANTS[name], "best_step": summary["best"]["step"],
                     "stopped_early_at": summary.get("stopped_early_at"),
                     "validation_pose_loss": round(summary["best"]["value"], 5),
                     "prior_median_cm": round(100 * ungated["prior_median_m"], 2),
                     "residual_median_cm": round(100 * ungated["prior_plus_residual_median_m"], 2),
                     "residual_within_2cm": ungated["prior_plus_residual_within_2cm"],
                     "rotation_error_rad": gate.get("rotation_clipped_error"),
                     "rotation_error_rad_prior": gate.get("rotation_clipped_error_prior"),
                     "gate": [gate.get("translation_scale"), gate.get("rotation_scale")],
                     "train_samples": summary["train_samples"], "wall_time_s": summary["wall_time_s"]})
        print(rows[-1], flush=True)
    command = invoked_command()
    val = sorted({int(p.stem.rsplit("_", 1)[1]) for p in Path(args.validation_data).glob("*/episode_*.h5")})
    notes = ("validation demos only (never test seeds); errors are of prior + residual before the output gate, "
             "the rotation error clipped at 0.35 rad as the gate scores it; one task: a first reading, not a verdict")
    path = write_result(args.out, command, {"train": list(range(args.demos)), "validation": val}, started, rows,
                        notes=notes)
    print(f"wrote {path}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
