"""Does the memory's confidence threshold ever decide anything? (writes results/retrieval_keys.json)

    .venv/bin/python benchmarks/investigations/retrieval_keys.py --runs runs/residual_space_peract_v2 \
        --method no_refinement \
        --results results/residual_space/peract_suite_v2

Two measurements, both from a finished benchmark run (no rollout):
1. per task, the rate at which retrieval fired in the recorded episodes and the nearest similarity it saw
   (``keyframes.jsonl``, the first keyframe's log);
2. the cosine similarity of the memory keys of every pair of tasks (each task's bank holds its training demos'
   keys): within a task (leave-one-out) and across tasks, against the threshold the banks were built with.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.memory.bank import MemoryBank
from bimanualshift.methods.bimanualshift import MEMORY_FILE
from bimanualshift.utils.jsonl import read_records
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def firing_rows(results: Path, method: str) -> list[dict]:
    """Per task: episodes, the share in which retrieval fired, and the nearest similarity's min / median."""
    seen: dict[str, list[dict]] = {}
    for record in read_records(results / "keyframes.jsonl"):
        if record["method"] == method and record["steps"]:
            seen.setdefault(record["task"], []).append(record["steps"][0]["policy"]["retrieval"])
    rows = []
    for task, retrievals in seen.items():
        similarities = [r["similarity"] for r in retrievals if r["similarity"] is not None]
        rows.append({"measure": "episodes", "task": task, "episodes": len(retrievals),
                     "fired": round(float(np.mean([r["fired"] for r in retrievals])), 4),
                     "nearest_min": round(min(similarities), 4),
                     "nearest_median": round(float(np.median(similarities)), 4)})
    return rows


def key_rows(banks: dict[str, MemoryBank]) -> list[dict]:
    """Per (task, other task): the largest and the median cosine between their banks' keys (a key never with
    itself)."""
    rows = []
    for task, bank in banks.items():
        for other, other_bank in banks.items():
            similarity = bank.keys() @ other_bank.keys().T
            if task == other:
                similarity = similarity[~np.eye(len(similarity), dtype=bool)]
            rows.append({"measure": "keys", "task": task, "other": other, "threshold": bank.threshold,
                         "max": round(float(similarity.max()), 4), "median": round(float(np.median(similarity)), 4)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", default="runs/residual_space_peract_v2", help="a bench's --runs folder")
    parser.add_argument("--method", default="no_refinement", help="the method whose banks and episodes are read")
    parser.add_argument("--results", default="results/residual_space/peract_suite_v2", help="that bench's --out")
    parser.add_argument("--out", default="results/retrieval_keys.json")
    args = parser.parse_args()
    started = time.time()
    banks = {path.parent.parent.parent.name: MemoryBank.load(path)
             for path in sorted(Path(args.runs).glob(f"*/{args.method}/best/{MEMORY_FILE}"))}
    if not banks:
        raise SystemExit(f"no memory banks under {args.runs}/*/{args.method}/best/: run the benchmark first "
                         "(the command in this file's docstring)")
    rows = firing_rows(Path(args.results), args.method) + key_rows(banks)
    within = [r for r in rows if r["measure"] == "keys" and r["task"] == r["other"]]
    across = [r for r in rows if r["measure"] == "keys" and r["task"] != r["other"]]
    summary = {"within_task_median_min": min(r["median"] for r in within),
               "across_tasks_max": max(r["max"] for r in across)}
    command = invoked_command()
    notes = (f"keys of the training demos' banks ({args.runs}/<task>/{args.method}/best/{MEMORY_FILE}); "
             f"episodes from {args.results}/keyframes.jsonl")
    path = write_result(args.out, command, {}, started, rows, notes=notes, summary=summary)
    for row in rows:
        print(row)
    print(summary)
    print(f"wrote {path}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
