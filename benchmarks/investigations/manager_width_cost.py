"""Trainable (Manager, Z, G) against frozen (prior) parameters of trained BimanualShift checkpoints, counted as
the loaded networks' parameters (buffers such as input statistics left out; writes a result file): the cost
column of docs/residual.md's width table.

    .venv/bin/python benchmarks/investigations/manager_width_cost.py runs/issue54_width/take_tray_out_of_oven \
        --out results/issue54/width_cost.json
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from bimanualshift.evaluation.report import write_result
from bimanualshift.methods.bimanualshift import checkpoint_prior
from bimanualshift.priors.base import UnimanualPrior, resolve_prior_path
from bimanualshift.residual.checkpoint import load_residual_checkpoint, read_residual_config
from bimanualshift.utils.config_files import read_json_file
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def trainable_parameters(best: Path) -> int:
    config, _ = read_residual_config(best)
    _, residual = load_residual_checkpoint(best, config["residual"]["text_dim"])
    return sum(p.numel() for p in residual.parameters())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", help="a task's folder of method runs (each with best/)")
    parser.add_argument("--out", default="results/issue54/width_cost.json")
    args = parser.parse_args()
    started = time.time()
    rows = []
    for best in sorted(Path(args.runs).glob("*/best")):
        config = read_json_file(best / "config.json")
        prior = resolve_prior_path(checkpoint_prior(best, str(config["prior"])))
        trainable = trainable_parameters(best)
        frozen = sum(p.numel() for p in UnimanualPrior.from_pretrained(prior).parameters())
        rows.append({"run": best.parent.name, "hidden": config["residual"]["hidden"], "trainable": trainable,
                     "frozen": frozen, "trainable_over_frozen": round(trainable / frozen, 3)})
        print(f"{best.parent.name:16s} hidden {rows[-1]['hidden']:4d}  {trainable:9,d} / {frozen:,d} = "
              f"{rows[-1]['trainable_over_frozen']}")
    write_result(args.out, " ".join(["python", *sys.argv]), {}, started, rows,
                 notes="nn.Parameters of each loaded residual and of its prior")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
