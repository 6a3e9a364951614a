"""How long the benchmark's parts take (writes results/bench_speed.json).

    .venv/bin/python benchmarks/bench_speed.py --task push_two_buttons --demos 30 --episodes 20

* training wall time of BimanualShift (residual only, prior frozen) and of the from-scratch bimanual voxel
  baseline on the same demos, to each one's best validation checkpoint and in total;
* evaluation episodes per minute with 1 and 2 rollout workers (the frozen-prior-per-arm method, so the
  number measures the harness and the simulator rather than one method's network).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.bench import BenchConfig, run_bench
from bimanualshift.evaluation.report import write_result
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def best_time(run: Path) -> tuple[float, float, int]:
    """(seconds to the best validation checkpoint, seconds in total, best step) from a run's history."""
    history = json.loads((run / "history.json").read_text())
    best = history["best"]["step"]
    at_best = next(h["elapsed_s"] for h in history["history"] if h["step"] == best)
    return float(at_best), float(history["history"][-1]["elapsed_s"]), int(best)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="push_two_buttons")
    parser.add_argument("--demos", type=int, default=30)
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--prior", default="peract_suite")
    parser.add_argument("--data", default="data/bench")
    parser.add_argument("--out", default="results/bench_speed.json")
    args = parser.parse_args()
    started = time.time()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        base = BenchConfig(tasks=[args.task], demos=args.demos, episodes=args.episodes, prior=args.prior,
                           data=args.data, runs=f"{tmp}/runs", videos=0)
        for method in ("bimanualshift", "scratch_voxel"):
            run_bench(replace(base, methods=[method], episodes=0, out=f"{tmp}/train_{method}"), command="bench_speed")
            to_best, total, step = best_time(Path(tmp) / "runs" / args.task / method)
            rows.append({"what": f"train {method} on {args.demos} demos", "seconds_to_best": round(to_best, 1),
                         "seconds_total": round(total, 1), "best_step": step})
        for workers in (1, 2):
            t0 = time.time()
            run_bench(replace(base, methods=["frozen_prior_per_arm"], workers=workers, out=f"{tmp}/eval_{workers}"),
                      command="bench_speed")
            minutes = (time.time() - t0) / 60
            rows.append({"what": f"evaluation, {workers} worker(s)", "episodes": args.episodes,
                         "episodes_per_min": round(args.episodes / minutes, 2)})
    for r in rows:
        print(r)
    command = (f"python benchmarks/bench_speed.py --task {args.task} --demos {args.demos} --episodes {args.episodes} "
               f"--prior {args.prior}")
    write_result(args.out, command, {"train": split_seeds("train", args.demos),
                                     "test": split_seeds("test", args.episodes)}, started, rows,
                 notes="training times are optimisation + validation after data loading (the runs' own clocks); "
                       "episodes per minute include starting the worker processes and loading the policy")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
