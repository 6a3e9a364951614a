"""Two methods of one bench folder compared episode by episode on the seeds both ran (writes a result file)

    .venv/bin/python benchmarks/paired_comparison.py results/residual_space/gripper_down_quaternions \
        --methods balanced_residual gripper_down_quaternions
    .venv/bin/python benchmarks/paired_comparison.py results/generalisation/perturbations \
        --methods bimanualshift peract_lf --perturbation all
    .venv/bin/python benchmarks/paired_comparison.py results/residual_space/object_boxes \
        --methods object_boxes no_refinement --against results/residual_space/refine_memory
    .venv/bin/python benchmarks/paired_comparison.py results/episodes100/table1 --methods bimanualshift peract_lf

Both methods roll out the same seeds, so the episodes where they disagree carry the whole difference: per task and
over all tasks, how many each one wins and the exact two-sided sign test's p (``evaluation.stats``). Reads the
folder's ``episodes.jsonl`` (method B's from ``--against``'s when its episodes were recorded in another folder on the
same seeds); nothing is rolled out. A study folder (`results/table1`), whose task groups each hold an
``episodes.jsonl``, is read whole. ``--perturbation`` picks the episodes of one perturbation
(``none``, the default, for a folder without perturbations) or ``all`` of them, one row per task and perturbation.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.evaluation.stats import pair_by_scene, paired_sign_test
from bimanualshift.utils.jsonl import read_records
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", help="a bench result folder holding episodes.jsonl, or a study folder whose "
                                           "subfolders hold them")
    parser.add_argument("--methods", nargs=2, required=True, metavar=("A", "B"))
    parser.add_argument("--perturbation", default="none",
                        help="the perturbation whose episodes are paired, or `all` (default: none)")
    parser.add_argument("--against", default="",
                        help="read method B's episodes from this bench folder instead (the same seeds, another run)")
    parser.add_argument("--out", default="", help="result file (default: FOLDER/paired_A_vs_B.json)")
    args = parser.parse_args()
    started = time.time()
    path, other = Path(args.folder), Path(args.against or args.folder)
    files, other_files = episode_logs(path), episode_logs(other)
    a, b = args.methods
    # a task's key is "task" for one perturbation, "task (perturbation)" for all of them
    # A's and B's outcome per (task, seed), kept apart: A and B may share a name
    success: tuple[dict[tuple[str, int], bool], dict[tuple[str, int], bool]] = ({}, {})
    perturbations = set()
    if a == b and other == path:
        sys.exit(f"error: --methods names {a} twice: compare two methods, or one with its run in --against")
    # a line cut short by a study still writing is skipped
    records = [(row, 0) for file in files for row in read_records(file)]
    records += ([(row, 1) for file in other_files for row in read_records(file)] if other != path
                else [(row, 1) for row, _ in records])
    for row, side in records:
        perturbation = row.get("perturbation", "none")
        perturbations.add(perturbation)
        if row["method"] == (a, b)[side] and args.perturbation in ("all", perturbation):
            task = row["task"] if args.perturbation != "all" else f"{row['task']} ({perturbation})"
            success[side][(task, int(row["seed"]))] = bool(row["success"])
    if not any(success) and args.perturbation not in perturbations:
        sys.exit(f"error: no episode of perturbation {args.perturbation!r} in {path}; it holds "
                 f"{', '.join(sorted(perturbations))} (or pass --perturbation all)")
    if a == b:  # one method's two runs: B is named by its folder in the result
        b = f"{b}@{Path(args.against).name}"
    rows, seeds = [], {}
    for task in sorted({task for task, _ in success[0]}):
        pairs, task_a, task_b = pair_by_scene({k: ok for k, ok in success[0].items() if k[0] == task}, success[1])
        if pairs:
            seeds[task] = [seed for _, seed in pairs]
            rows.append({"task": task, **_row(a, b, task_a, task_b)})
    if not rows:
        sys.exit(f"error: {a} and {b} share no seed in {path}{f' and {other}' if other != path else ''}: check the "
                 "method names")
    # "all" pools every row's pairs: the sign test counts a seed once per task and perturbation
    rows.append({"task": "all", **_row(a, b, *pair_by_scene(*success)[1:])})
    for row in rows:
        print(f"{row['task']}: {row['pairs']} pairs, {a} wins {row[f'{a}_wins']}, {b} wins {row[f'{b}_wins']}, "
              f"p = {row['p_value']}")
    out = args.out or str(path / f"paired_{a}_vs_{b}.json")
    command = invoked_command()
    write_result(out, command, seeds, started, rows,
                 notes=f"episodes of {', '.join(map(str, files))}"
                       f"{f' ({b}: ' + ', '.join(map(str, other_files)) + ')' if other != path else ''} (perturbation "
                       f"{args.perturbation}) where both methods ran the seed; "
                       "wins: episodes one method solved and "
                       "the other did not; p: exact two-sided sign test")
    print(f"wrote {out}")


def episode_logs(folder: Path) -> list[Path]:
    """The folder's ``episodes.jsonl``, or, for a study folder, each of its subfolders' (exits naming the folder)."""
    if (folder / "episodes.jsonl").is_file():
        return [folder / "episodes.jsonl"]
    logs = sorted(folder.glob("*/episodes.jsonl"))
    if not logs:
        sys.exit(f"error: {folder} holds no episodes.jsonl, nor do its subfolders: pass a folder written by "
                 "`bimanualshift bench` or `study`")
    return logs


def _row(a: str, b: str, flags_a: list[bool], flags_b: list[bool]) -> dict[str, float | int]:
    result = paired_sign_test(flags_a, flags_b)
    return {"pairs": result.pairs, f"{a}_success": round(sum(flags_a) / len(flags_a), 3),
            f"{b}_success": round(sum(flags_b) / len(flags_b), 3), f"{a}_wins": result.a_wins,
            f"{b}_wins": result.b_wins, "p_value": round(result.p_value, 4)}


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
