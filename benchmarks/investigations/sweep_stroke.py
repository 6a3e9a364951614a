"""Where the brush is set down at sweep's stroke start, against the expert, in failures and successes (writes
results/sweep_stroke.json)

    .venv/bin/python benchmarks/investigations/sweep_stroke.py results/table1/complex_tasks

The expert sets the brush head down (keyframe 5) just beyond the farthest dirt from the pan's mouth and strokes
towards the mouth (keyframe 6). Per method and outcome, from a bench folder's per-keyframe log (``keyframes.jsonl``):
the brush arm's executed keyframe-5 position minus the expert's on the same seed, split along the stroke (positive:
farther from the pan, behind the dirt; negative: short, onto the dirt) and across it. The brush arm is the one
whose expert keyframes 4 and 6 lie farthest apart. Also, at keyframe 5, how far the brush head is turned from the
expert's (the gripper's heading about the vertical, modulo a half turn), and at keyframe 6 where the stroke ends
along it (positive: stopped before the expert's end, short of the pan's mouth). And the other arm's grasp of the
dustpan's handle at keyframe 2 (closed on it), turned from the expert's about the vertical, and for methods on a frozen
prior the prior's own proposal there (before the residual). Nothing is rolled out.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.utils.jsonl import read_records
from bimanualshift.utils.pipes import quiet_on_closed_pipe

TASK = "sweep_to_dustpan"
ABOVE, DOWN, END = 4, 5, 6  # the expert's keyframes: above the stroke start, at it, at the stroke's end
PAN_HELD = 2  # the dustpan arm's first keyframe closed on the handle
SHORT_M = 0.01  # "short": set down more than this nearer the pan than the expert


class StrokeOffsets(NamedTuple):
    along: float  # metres, keyframe 5, + farther from the pan than the expert
    across: float  # metres, keyframe 5
    turn: float  # radians in [-pi/2, pi/2), keyframe 5: the head's heading minus the expert's
    end_along: float  # metres, keyframe 6, + stopped before the expert's stroke end
    pan_turn: float  # radians in [-pi/2, pi/2), keyframe 2: the dustpan arm's heading minus the expert's
    prior_pan_turn: float  # the same for the frozen prior's proposal; NaN for a method without one


def _half_turn(angle: float) -> float:
    """An angle between two parallel-gripper headings, which look the same every half turn: in [-pi/2, pi/2)."""
    return float((angle + np.pi / 2) % np.pi - np.pi / 2)


def _heading(quat: np.ndarray) -> float:
    """The gripper's heading about the vertical: its x axis projected on the table ((x, y, z, w) quaternion)."""
    x = Rotation.from_quat(quat).apply([1.0, 0.0, 0.0])
    return float(np.arctan2(x[1], x[0]))


def stroke_offsets(steps: list[dict[str, Any]]) -> StrokeOffsets | None:
    """The brush arm's set-down and stroke end against the expert's, or None when the episode did not reach the
    expert's stroke."""
    rows = {s["keyframe"]: s for s in steps}
    if any(k not in rows or rows[k]["expert"] is None for k in (PAN_HELD, ABOVE, DOWN, END)):
        return None
    expert = {k: np.asarray(rows[k]["expert"]) for k in (PAN_HELD, ABOVE, DOWN, END)}
    arm = int(np.argmax(np.linalg.norm(expert[ABOVE][:, :2] - expert[END][:, :2], axis=1)))
    along = expert[ABOVE][arm, :2] - expert[END][arm, :2]
    along /= np.linalg.norm(along)
    down = np.asarray(rows[DOWN]["executed"])[arm]
    offset = down[:2] - expert[DOWN][arm, :2]
    turn = _heading(down[3:7]) - _heading(expert[DOWN][arm, 3:7])
    end = np.asarray(rows[END]["executed"])[arm, :2] - expert[END][arm, :2]
    pan = 1 - arm
    expert_heading = _heading(expert[PAN_HELD][pan, 3:7])
    pan_turn = _heading(np.asarray(rows[PAN_HELD]["executed"])[pan, 3:7]) - expert_heading
    arms = (rows[PAN_HELD].get("policy") or {}).get("arms") or []
    prior = arms[pan].get("prior") if len(arms) > pan else None
    prior_turn = _half_turn(_heading(np.asarray(prior)[3:7]) - expert_heading) if prior else float("nan")
    return StrokeOffsets(float(offset @ along), float(offset @ np.array([-along[1], along[0]])), _half_turn(turn),
                         float(end @ along), _half_turn(pan_turn), prior_turn)


def summarise(folder: Path) -> list[dict[str, Any]]:
    success = {(e["method"], e["seed"]): e["success"] for e in read_records(folder / "episodes.jsonl")
               if e["task"] == TASK and e.get("perturbation", "none") == "none"}
    offsets: dict[tuple[str, bool], list[StrokeOffsets]] = defaultdict(list)
    for record in read_records(folder / "keyframes.jsonl"):
        key = (record["method"], record["seed"])
        if record["task"] != TASK or key not in success or record.get("perturbation", "none") != "none":
            continue
        found = stroke_offsets(record["steps"])
        if found is not None:
            offsets[(record["method"], success[key])].append(found)
    rows = []
    for (method, succeeded), values in sorted(offsets.items()):
        a = np.asarray(values)
        rows.append({"method": method, "outcome": "success" if succeeded else "failure", "episodes": len(a),
                     "along_median_cm": round(100 * float(np.median(a[:, 0])), 1),
                     "short_fraction": round(float(np.mean(a[:, 0] < -SHORT_M)), 2),
                     "across_abs_median_cm": round(100 * float(np.median(np.abs(a[:, 1]))), 1),
                     "turn_abs_median_deg": round(float(np.degrees(np.median(np.abs(a[:, 2])))), 1),
                     "end_along_median_cm": round(100 * float(np.median(a[:, 3])), 1),
                     "pan_turn_abs_median_deg": round(float(np.degrees(np.median(np.abs(a[:, 4])))), 1),
                     "prior_pan_turn_abs_median_deg": None if np.isnan(a[:, 5]).any()
                     else round(float(np.degrees(np.median(np.abs(a[:, 5])))), 1)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folder", help="a bench folder holding sweep_to_dustpan's episodes.jsonl and keyframes.jsonl")
    parser.add_argument("--out", default="results/sweep_stroke.json")
    args = parser.parse_args()
    started = time.time()
    folder = Path(args.folder)
    if not (folder / "keyframes.jsonl").is_file():
        raise SystemExit(f"{folder} has no keyframes.jsonl: give a bench folder (e.g. results/table1/complex_tasks)")
    rows = summarise(folder)
    if not rows:
        raise SystemExit(f"{folder} holds no {TASK} episodes that reached the expert's stroke")
    print(f"{'method':<22} {'outcome':<8} {'n':>3} {'along cm':>9} {'short':>6} {'|across| cm':>12} "
          f"{'|turn| deg':>11} {'end cm':>7} {'|pan turn| deg':>15} {'prior':>6}")
    for r in rows:
        print(f"{r['method']:<22} {r['outcome']:<8} {r['episodes']:>3} {r['along_median_cm']:>9} "
              f"{r['short_fraction']:>6} {r['across_abs_median_cm']:>12} {r['turn_abs_median_deg']:>11} "
              f"{r['end_along_median_cm']:>7} {r['pan_turn_abs_median_deg']:>15} "
              f"{'-' if r['prior_pan_turn_abs_median_deg'] is None else r['prior_pan_turn_abs_median_deg']:>6}")
    seeds = sorted({e["seed"] for e in read_records(folder / "episodes.jsonl") if e["task"] == TASK})
    write_result(args.out, invoked_command(), {"test": seeds}, started, rows, folder=str(folder),
                 notes="brush arm's keyframe-5 position minus the expert's: along the stroke (+ farther from the "
                 f"pan) and across it; short = more than {100 * SHORT_M:.0f} cm nearer the pan; turn: the head's "
                 "heading minus the expert's at keyframe 5 (modulo a half turn); end_along: keyframe 6 minus the "
                 "expert's along the stroke (+ stopped before the expert's end); pan_turn: the dustpan arm's heading "
                 "minus the expert's at keyframe 2 (prior_pan_turn: the frozen prior's proposal's, for methods on "
                 "one); medians over episodes")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
