"""Where a grasp keyframe's error comes from, read from a bench folder's per-keyframe log (writes a result file)

    .venv/bin/python benchmarks/keyframe_precision.py results/issue54/closed_loop_choice \
        --methods no_refinement --out results/keyframe_precision.json

A prior report's keyframe log (``prior-report --out X.json`` writes ``X.keyframes.jsonl``) reads the same way, the
prior's name standing for the method: there the one arm drives alone and ``prior`` and ``policy`` coincide.

At each arm's first grasp keyframe (the first keyframe at which the scripted expert closes that arm's gripper on the
same seed), the distance to the expert's pose is split into the chain that produced it:

- ``prior``: the frozen prior's proposal, in the bimanual scene after the projection (the policy's own log);
- ``policy``: the action executed (the prior plus the residual);
- ``executor``: where the arm ended against where it was sent (``reached`` against ``executed``);
- ``reached``: where the arm ended against the expert's pose: what the task sees.

Rotations are measured to the expert's grasp or its half-turn twin about the gripper's axis, whichever is nearer
(the same parallel grasp). Each is given as median and quartiles in cm and degrees, per task and over all of them,
with the share of grasps within 1 cm and 5 degrees (the precision target). The prior alone in its own arm frame,
on its pretraining suite, is ``prior-report``'s keyframe error (results/priors*.json). Nothing is rolled out; the
folder's ``keyframes.jsonl`` must log ``reached`` (recorded since the executor started logging it).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.geometry.frames import nearest_grasp_twin
from bimanualshift.utils.jsonl import read_records
from bimanualshift.utils.pipes import quiet_on_closed_pipe

TERMS = ("prior", "policy", "executor", "reached")
TARGET_CM, TARGET_DEG = 1.0, 5.0


def angle_deg(q1: np.ndarray, q2: np.ndarray) -> float:
    """The rotation between two (x, y, z, w) quaternions, in degrees (either sign of a quaternion is one pose)."""
    a, b = q1 / np.linalg.norm(q1), q2 / np.linalg.norm(q2)
    return float(np.degrees(2 * np.arccos(min(1.0, abs(float(np.dot(a, b)))))))


def grasp_angle_deg(quat: np.ndarray, expert: np.ndarray) -> float:
    """The rotation from ``quat`` to the expert's grasp or its half-turn twin about the gripper's axis, whichever is
    nearer: a parallel gripper closes the same way in both."""
    return angle_deg(quat, nearest_grasp_twin(expert, quat))


def first_grasps(steps: list[dict[str, Any]]) -> dict[int, int]:
    """Arm index -> the index (in ``steps``) of its first keyframe whose expert row closes the gripper."""
    found: dict[int, int] = {}
    for i, row in enumerate(steps):
        for arm, expert in enumerate(row.get("expert") or []):
            if arm not in found and expert[7] < 0.5:
                found[arm] = i
    return found


def grasp_errors(steps: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per arm's first grasp: each term's (cm, degrees) from the expert's pose (the executor's: from the command)."""
    out = []
    for arm, i in sorted(first_grasps(steps).items()):
        row = steps[i]
        expert, executed = np.asarray(row["expert"][arm]), np.asarray(row["executed"][arm])
        terms: dict[str, tuple[float, float]] = {}
        arms_log = (row.get("policy") or {}).get("arms") or []
        if arm < len(arms_log) and arms_log[arm].get("prior") is not None:
            prior = np.asarray(arms_log[arm]["prior"])
            terms["prior"] = (100 * float(np.linalg.norm(prior[:3] - expert[:3])),
                              grasp_angle_deg(prior[3:7], expert[3:7]))
        terms["policy"] = (100 * float(np.linalg.norm(executed[:3] - expert[:3])),
                           grasp_angle_deg(executed[3:7], expert[3:7]))
        if row.get("reached") is not None:
            reached = np.asarray(row["reached"][arm])
            terms["executor"] = (100 * float(np.linalg.norm(reached[:3] - executed[:3])),
                                 angle_deg(reached[3:7], executed[3:7]))
            terms["reached"] = (100 * float(np.linalg.norm(reached[:3] - expert[:3])),
                                grasp_angle_deg(reached[3:7], expert[3:7]))
        out.append({"arm": arm, "keyframe": int(row["keyframe"]), **terms})
    return out


def summarise(grasps: list[dict[str, Any]]) -> dict[str, Any]:
    summary: dict[str, Any] = {"grasps": len(grasps)}
    for term in TERMS:
        values = np.array([g[term] for g in grasps if term in g], dtype=np.float64).reshape(-1, 2)
        if not len(values):
            continue
        cm, deg = values[:, 0], values[:, 1]
        summary[term] = {"cm": [round(float(q), 2) for q in np.percentile(cm, [25, 50, 75])],
                         "deg": [round(float(q), 1) for q in np.percentile(deg, [25, 50, 75])],
                         "within_target": round(float(np.mean((cm <= TARGET_CM) & (deg <= TARGET_DEG))), 3)}
    return summary


def precision_rows(folder: Path, methods: list[str], success: bool | None = None,
                   seeds: dict[str, list[int]] | None = None) -> list[dict[str, Any]]:
    """Rows per (task, method) and pooled per method; ``seeds``, if given, collects each task's seeds read."""
    if folder.is_file():  # a prior report's X.keyframes.jsonl, its episodes in X.episodes.jsonl
        log = folder
        episodes = folder.with_name(folder.name.replace(".keyframes.jsonl", ".episodes.jsonl"))
    else:
        log, episodes = folder / "keyframes.jsonl", folder / "episodes.jsonl"
    if not log.is_file():
        raise FileNotFoundError(f"{folder} holds no keyframes.jsonl: give a bench result folder or a prior "
                                "report's .keyframes.jsonl")
    outcomes = {(e["task"], e.get("method", e.get("prior")), e.get("perturbation", "none"), e["seed"]):
                bool(e["success"]) for e in read_records(episodes)} if episodes.is_file() else {}
    by_cell: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for record in read_records(log):
        if record["method"] not in methods or record.get("perturbation", "none") != "none":
            continue
        key = (record["task"], record["method"], "none", record["seed"])
        if success is not None and outcomes.get(key) is not success:
            continue
        by_cell.setdefault((record["task"], record["method"]), []).extend(grasp_errors(record["steps"]))
        if seeds is not None:
            seeds.setdefault(record["task"], []).append(int(record["seed"]))
    if not by_cell:
        raise ValueError(f"{log} logs no unperturbed episode of {', '.join(methods)}")
    rows = [{"task": task, "method": method, **summarise(grasps)} for (task, method), grasps in sorted(by_cell.items())]
    for method in methods:
        pooled = [g for (_, m), grasps in by_cell.items() if m == method for g in grasps]
        if pooled:
            rows.append({"task": "all", "method": method, **summarise(pooled)})
    return rows


def markdown(rows: list[dict[str, Any]]) -> str:
    lines = ["| task | method | grasps | " + " | ".join(f"{t} cm / deg (median)" for t in TERMS) +
             " | reached within 1 cm and 5 deg |", "|---|---|---|" + "---|" * (len(TERMS) + 1)]
    for r in rows:
        cells = [f"{r[t]['cm'][1]} / {r[t]['deg'][1]}" if t in r else "–" for t in TERMS]
        share = f"{100 * r['reached']['within_target']:.0f} %" if "reached" in r else "–"
        lines.append(f"| {r['task']} | {r['method']} | {r['grasps']} | " + " | ".join(cells) + f" | {share} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", help="a bench result folder holding keyframes.jsonl, or a prior report's "
                                           ".keyframes.jsonl (its priors are the methods)")
    parser.add_argument("--methods", nargs="+", required=True)
    parser.add_argument("--episodes", choices=("all", "successes", "failures"), default="all")
    parser.add_argument("--out", default="", help="result file (JSON) to write")
    args = parser.parse_args()
    started = time.time()
    success = {"all": None, "successes": True, "failures": False}[args.episodes]
    seeds: dict[str, list[int]] = {}
    try:
        rows = precision_rows(Path(args.folder), args.methods, success, seeds)
    except (FileNotFoundError, ValueError) as e:
        sys.exit(f"keyframe_precision: {e}")
    print(markdown(rows))
    if args.out:
        write_result(args.out, invoked_command(), {t: sorted(set(v)) for t, v in seeds.items()}, started,
                     rows=rows, notes=f"first grasp keyframe per arm; episodes: {args.episodes}; "
                                      "terms: the prior's proposal, the executed action and where the arm ended, "
                                      "each against the expert's pose, and the executor's own gap")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
