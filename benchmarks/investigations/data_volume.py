"""How much single-arm data a prior needs: validation keyframe error against demos per task (writes
results/data_volume.json).

    .venv/bin/python benchmarks/investigations/data_volume.py --prior peract --demos 25 50 100 --steps 3000 \
        --data data/suite2 --validation-data data/suite2_val

Each volume pretrains the same network for the same steps on each task's first N demos by seed (so a smaller
volume is a subset of a larger one) and is scored on the same validation demos, never on test seeds. Runs go to
``runs/data_volume/<prior>_<N>`` and resume when interrupted (run the same command again).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.training.configs import PretrainConfig
from bimanualshift.training.pretrain import pretrain
from bimanualshift.utils.config_files import config_from_flat
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--prior", default="peract")
    parser.add_argument("--model", default="{}", help="config-field overrides as JSON, e.g. '{\"dim\": 64}'")
    parser.add_argument("--demos", nargs="+", type=int, default=[25, 50, 100], help="demos per task")
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--batch-size", type=int, default=8)
    parser.add_argument("--data", default="data/suite2")
    parser.add_argument("--validation-data", default="data/suite2_val")
    parser.add_argument("--runs", default="runs/data_volume")
    parser.add_argument("--out", default="results/data_volume.json")
    args = parser.parse_args()
    started = time.time()
    rows = []
    for demos in args.demos:
        out = Path(args.runs) / f"{args.prior}_{demos}"
        cfg = config_from_flat(PretrainConfig, prior=args.prior, model=json.loads(args.model), tasks=["unimanual"],
                               data=args.data, validation_data=args.validation_data, episodes_per_task=demos,
                               out=str(out), steps=args.steps, batch_size=args.batch_size, lr=1e-3,
                               optimizer="lamb", schedule="cosine", warmup_steps=min(500, args.steps // 10),
                               checkpoint_every=max(1, args.steps // 6))
        best = pretrain(cfg)
        history = json.loads((out / "history.json").read_text())["history"]
        config = json.loads((best / "config.json").read_text())
        last, chosen = history[-1], next(h for h in history if h["step"] == config["trained_steps"])
        rows.append({"prior": args.prior, "demos_per_task": demos, "train_episodes": config["train_episodes"],
                     "steps": args.steps, "best_step": chosen["step"],
                     "within_3cm": round(-chosen["validation"], 4),
                     "median_translation_cm": chosen.get("validation_median_cm"),
                     "median_rotation_deg": chosen.get("validation_median_deg"),
                     "final_within_3cm": round(-last["validation"], 4),
                     "training_time_s": config["training_time_s"]})
        print(rows[-1], flush=True)
    command = invoked_command()
    notes = ("teacher-forced keyframe error on the validation demos at the step validation picked (and at the "
             "last step); every volume trains the same steps with the same schedule and batch")
    val_seeds = sorted({int(p.stem.rsplit("_", 1)[1]) for p in Path(args.validation_data).glob("*/episode_*.h5")})
    path = write_result(args.out, command, {"train": list(range(max(args.demos))), "validation": val_seeds},
                        started, rows, notes=notes)
    print(f"wrote {path}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
