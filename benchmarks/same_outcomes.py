"""Per-seed outcomes of a fresh benchmark run against the ones a committed results folder recorded
(results/same_outcomes.json): do recorded studies stay valid under today's code?

    .venv/bin/python benchmarks/same_outcomes.py --recorded results/episodes100/table1/simpler_tasks \
        --rerun results/recheck --out results/same_outcomes.json

``--rerun`` is a folder written by ``bimanualshift bench`` on the same seeds (for example
``bimanualshift bench --tasks lift_ball --methods frozen_prior_per_arm no_residual --prior peract_suite_v2
--episodes 30 --out results/recheck``). Every (task, method, perturbation, seed) recorded in both is compared: success,
keyframes and stages reached; where both carry it, the digest of the executed actions as well.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict

from bimanualshift.evaluation.bench import read_episodes
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.utils.pipes import quiet_on_closed_pipe

KEYS = ("task", "method", "perturbation", "seed")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--recorded", required=True, help="a committed results folder (its episodes.jsonl)")
    parser.add_argument("--rerun", required=True, help="a bench folder run on the same seeds today")
    parser.add_argument("--out", default="results/same_outcomes.json")
    parser.add_argument("--note", default="")
    args = parser.parse_args()
    started = time.time()

    def indexed(folder: str) -> dict[tuple, dict]:
        return {tuple(e.get(k, "none") for k in KEYS): e for e in read_episodes(f"{folder}/episodes.jsonl")}

    recorded, rerun = indexed(args.recorded), indexed(args.rerun)
    shared = sorted(set(recorded) & set(rerun))
    if not shared:
        raise SystemExit(f"no (task, method, perturbation, seed) is recorded in both {args.recorded} and {args.rerun}")
    cells: dict[tuple[str, str, str], list[tuple]] = defaultdict(list)
    for key in shared:
        cells[key[:3]].append(key)
    rows, differing = [], []
    for (task, method, perturbation), keys in sorted(cells.items()):
        same = [k for k in keys if all(recorded[k].get(f) == rerun[k].get(f) for f in ("success", "keyframes",
                                                                                      "stages_done"))]
        digests = [k for k in keys if recorded[k].get("actions_sha256") and rerun[k].get("actions_sha256")]
        rows.append({"task": task, "method": method, "perturbation": perturbation, "episodes": len(keys),
                     "same_outcome": len(same), "recorded_success": sum(bool(recorded[k]["success"]) for k in keys),
                     "rerun_success": sum(bool(rerun[k]["success"]) for k in keys),
                     "same_actions": sum(recorded[k]["actions_sha256"] == rerun[k]["actions_sha256"] for k in digests),
                     "compared_actions": len(digests)})
        differing += [{"task": task, "method": method, "seed": k[3], "recorded": bool(recorded[k]["success"]),
                       "rerun": bool(rerun[k]["success"])} for k in keys if k not in same]
        print(f"{task:24s} {method:22s} same outcome on {len(same)}/{len(keys)} seeds")
    total = sum(r["same_outcome"] for r in rows)
    print(f"same outcome on {total} of {len(shared)} episodes")
    write_result(args.out, invoked_command(), {"test": sorted({k[3] for k in shared})}, started, rows,
                 notes=f"recorded: {args.recorded}; re-run: {args.rerun}" + (f"; {args.note}" if args.note else ""),
                 same_outcome=total, episodes=len(shared), differing=differing)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
