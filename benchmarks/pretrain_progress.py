"""Validation figures of pretraining runs so far, from their history.json (writes results/pretraining_progress.json
and prints a markdown table).

    .venv/bin/python benchmarks/pretrain_progress.py runs/prior_rvt_dense runs/prior_peract_v2

Per checkpoint: keyframes of the validation demos within 3 cm (what picks a run's best/) and 1 cm, the median
translation error (a coarse-to-fine prior's first stage too), the median rotation error, and the training time.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def progress_rows(run: Path) -> list[dict]:
    history = json.loads((run / "history.json").read_text())["history"]
    config = json.loads((run / "config.json").read_text())
    earlier = 0.0
    if config["network"].get("init_from"):
        start = json.loads((Path(config["network"]["init_from"]) / "config.json").read_text())
        earlier = float(start.get("training_time_s") or 0.0)
    rows = []
    for h in history:
        if "validation_median_cm" not in h:
            continue
        rows.append({"run": str(run), "prior": config["network"]["prior"], "step": h["step"],
                     "within_3cm": round(-h["validation"], 4), "within_1cm": h.get("validation_within_1cm"),
                     "median_translation_cm": h["validation_median_cm"],
                     "median_translation_cm_stage1": h.get("validation_median_cm_stage1"),
                     "median_rotation_deg": h.get("validation_median_deg"),
                     "training_time_min": round((earlier + h["elapsed_s"]) / 60, 1)})
    return rows


def table(rows: list[dict]) -> str:
    lines = ["| run | step | within 3 cm | within 1 cm | median cm (stage 1) | median ° | training min (cumulative) |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        stage1 = f" ({r['median_translation_cm_stage1']:.2f})" if r["median_translation_cm_stage1"] else ""
        lines.append(f"| {Path(r['run']).name} | {r['step']:,} | {100 * r['within_3cm']:.1f} % | "
                     f"{100 * r['within_1cm']:.1f} % | {r['median_translation_cm']:.2f}{stage1} | "
                     f"{r['median_rotation_deg']:.1f} | {r['training_time_min']} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+")
    parser.add_argument("--out", default="results/pretraining_progress.json")
    args = parser.parse_args()
    started = time.time()
    rows = [r for run in args.runs for r in progress_rows(Path(run))]
    command = invoked_command()
    notes = ("validation demos of data/suite2_val (validation seeds); training minutes include the run a prior was "
             "initialised from; runs that shared the 2 cores report the wall time they took that way")
    val = sorted({int(p.stem.rsplit("_", 1)[1]) for p in Path("data/suite2_val").glob("*/episode_*.h5")})
    write_result(args.out, command, {"validation": val}, started, rows, notes=notes)
    print(table(rows))


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
