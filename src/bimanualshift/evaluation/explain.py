"""Where each method's failures happen, from a bench folder's per-keyframe log (`bimanualshift explain`).

Every evaluated episode's keyframes are logged with the scripted expert's action at the same index on the same
seed and the poses the arms reached (``rollout.keyframe_row``). A failed episode is summarised by the stage it
reached and its first divergence:
the first keyframe at which an arm's executed action strays from the expert's (the refinement's tolerances:
3 cm, 20 degrees, or the other gripper state; as there, a gripper turned a half turn about its approach axis
counts as the same grasp), and which arm it was. Where the expert leads with one arm, an
episode also says whether the policy moved that arm first (a role swap otherwise).
"""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bimanualshift.core.arms import ARM_NAMES_BIMANUAL
from bimanualshift.evaluation.bench import KEYFRAME_LOG
from bimanualshift.evaluation.stats import episode_key
from bimanualshift.geometry.frames import gripper_angle_deg
from bimanualshift.registry import METHODS, get_method
from bimanualshift.utils.jsonl import read_records

TOLERANCE_M, TOLERANCE_DEG = 0.03, 20.0
# Which arm leads: the one the expert's plan moves farther over its first keyframes, when it moves at least
# LEAD_RATIO times as far as the other (symmetric plans, both arms reaching together, have no leader).
LEAD_KEYFRAMES, LEAD_RATIO = 6, 2.0
# The smallest gap between the failures' and the successes' median errors worth naming, in tolerances (1.5 cm, 10°)
GAP_SHOWN = 0.5


@dataclass(frozen=True)
class Divergence:
    keyframe: int
    arm: str  # an arm's name, or "-" when the policy ran past the expert's plan without straying before
    what: str  # "position / rotation / gripper", or "past the expert's plan"


def pose_error(mine: np.ndarray, theirs: np.ndarray) -> tuple[float, float]:
    """(metres, degrees) between an executed and an expert action row: the positions' distance and the grippers'
    angle, a half turn about the approach axis counting as none (``gripper_angle_deg``)."""
    return float(np.linalg.norm(mine[:3] - theirs[:3])), gripper_angle_deg(mine[3:7], theirs[3:7])


def first_divergence(steps: list[dict[str, Any]], arms: tuple[str, ...] = ARM_NAMES_BIMANUAL) -> Divergence | None:
    """The first keyframe at which an arm's executed action strays from the expert's at the same index (a
    gripper turned a half turn about its approach axis is the same grasp: ``gripper_angle_deg``)."""
    for row in steps:
        if row["expert"] is None:
            return Divergence(row["keyframe"], "-", "past the expert's plan")
        executed, expert = np.asarray(row["executed"]), np.asarray(row["expert"])
        for i, (mine, theirs) in enumerate(zip(executed, expert)):
            metres, degrees = pose_error(mine, theirs)
            what = [name for name, off in (
                ("position", metres > TOLERANCE_M),
                ("rotation", degrees > TOLERANCE_DEG),
                ("gripper", (mine[7] > 0.5) != (theirs[7] > 0.5))) if off]
            if what:
                return Divergence(row["keyframe"], arms[i] if i < len(arms) else str(i), " + ".join(what))
    return None


def lead_arms(steps: list[dict[str, Any]], arms: tuple[str, ...] = ARM_NAMES_BIMANUAL
              ) -> tuple[str, str] | None:
    """(the arm the expert's plan leads with, the arm the policy moved farther) over the first keyframes both
    have, or None when the plan has no leading arm: a role swap (the policy moving the arm that should wait)
    shows as a mismatch."""
    rows = [r for r in steps[:LEAD_KEYFRAMES] if r["expert"] is not None]
    if len(rows) < 2:
        return None
    expert = np.asarray([r["expert"] for r in rows])[:, :, :3]
    executed = np.asarray([r["executed"] for r in rows])[:, :, :3]
    plan = np.linalg.norm(np.diff(expert, axis=0), axis=-1).sum(0)
    if len(plan) != 2 or plan.max() < LEAD_RATIO * plan.min() or plan.max() < TOLERANCE_M:
        return None
    moved = np.linalg.norm(np.diff(executed, axis=0), axis=-1).sum(0)
    return arms[int(np.argmax(plan))], arms[int(np.argmax(moved))]


def first_keyframe_error_cm(steps: list[dict[str, Any]], arms: tuple[str, ...] = ARM_NAMES_BIMANUAL
                            ) -> dict[str, float] | None:
    """Per arm, how far (cm) the first executed position lies from the expert's on the same seed."""
    if not steps or steps[0]["expert"] is None:
        return None
    executed, expert = np.asarray(steps[0]["executed"]), np.asarray(steps[0]["expert"])
    return {arms[i] if i < len(arms) else str(i): round(100 * float(np.linalg.norm(a[:3] - b[:3])), 2)
            for i, (a, b) in enumerate(zip(executed, expert))}


def first_keyframe_summary(logs: list[list[dict[str, Any]]]) -> dict[str, float] | None:
    """Per arm, the median distance (cm) of the first executed position from the expert's over ``logs``' episodes,
    and, where the policy logs them, the median size of the residual it added there (a large residual that still
    lands far from the expert says the prior's proposal was far off and the residual could not carry it) and the
    median angle (degrees) between the prior's proposed orientation and the expert's (a half turn about the
    approach axis counting as none, as in :func:`first_divergence`)."""
    errors = [e for e in (first_keyframe_error_cm(steps) for steps in logs) if e]
    if not errors:
        return None
    values: dict[str, list[float]] = {}
    for e in errors:
        for arm, cm in e.items():
            values.setdefault(f"{arm} error", []).append(cm)
    for steps in (s for s in logs if s):  # an episode cut off before its first keyframe logs nothing
        for a in (steps[0].get("policy") or {}).get("arms", []):
            if a.get("residual_cm") is not None:
                values.setdefault(f"{a['arm']} residual", []).append(float(a["residual_cm"]))
        expert = steps[0].get("expert")
        for a in (steps[0].get("policy") or {}).get("arms", []) if expert is not None else []:
            i = ARM_NAMES_BIMANUAL.index(a["arm"]) if a.get("arm") in ARM_NAMES_BIMANUAL else -1
            if a.get("prior") is not None and 0 <= i < len(expert):
                values.setdefault(f"{a['arm']} prior turn", []).append(
                    gripper_angle_deg(np.asarray(a["prior"][3:7]), np.asarray(expert[i][3:7])))
    return {name: round(float(np.median(v)), 1) for name, v in values.items()}


def keyframe_profile(logs: list[list[dict[str, Any]]], arms: tuple[str, ...] = ARM_NAMES_BIMANUAL,
                     measured: str = "executed", reference: str = "expert") -> dict[str, list[list[float] | None]]:
    """Per arm and keyframe index, the median [cm, degrees] by which the executed action lies from the expert's over
    ``logs``' episodes (None where fewer than half of them reached that keyframe within the expert's plan). Set
    beside the successes' profile, it shows where the failures part from them, which the first divergence alone
    does not when the successes diverge at the same place. ``measured="reached", reference="executed"`` gives the
    tracking profile instead: how far the arms ended from what they were commanded (rows logged before the reached
    poses were are skipped)."""
    cells: dict[str, dict[int, list[tuple[float, float]]]] = {}
    for steps in logs:
        for row in steps:
            if row["expert"] is None:
                break
            if row.get(measured) is None or row.get(reference) is None:
                continue
            for i, (mine, theirs) in enumerate(zip(np.asarray(row[measured]), np.asarray(row[reference]))):
                arm = arms[i] if i < len(arms) else str(i)
                metres, degrees = pose_error(mine, theirs)
                cells.setdefault(arm, {}).setdefault(int(row["keyframe"]), []).append((100 * metres, degrees))
    profile: dict[str, list[list[float] | None]] = {}
    for arm, by_keyframe in cells.items():
        last = max(by_keyframe)
        profile[arm] = [None if len(by_keyframe.get(k, [])) * 2 < len(logs) else
                        [round(float(np.median([c for c, _ in by_keyframe[k]])), 1),
                         round(float(np.median([d for _, d in by_keyframe[k]])), 1)] for k in range(last + 1)]
    return profile


def widest_gap(failures: dict[str, list], successes: dict[str, list]) -> dict[str, Any] | None:
    """The keyframe, arm and measure at which the failures' median error exceeds the successes' most, in units of
    the divergence tolerances (3 cm, 20 degrees), or None when they never exceed them by ``GAP_SHOWN``."""
    best = None
    for arm, rows in failures.items():
        for k, (bad, good) in enumerate(zip(rows, successes.get(arm, []))):
            if bad is None or good is None:
                continue
            for j, (what, unit) in enumerate((("position", 100 * TOLERANCE_M), ("rotation", TOLERANCE_DEG))):
                gap = (bad[j] - good[j]) / unit
                if gap >= GAP_SHOWN and (best is None or gap > best["gap"]):
                    best = {"keyframe": k, "arm": arm, "what": what, "failures": bad[j], "successes": good[j],
                            "gap": round(gap, 2)}
    return best


def _retrieval(steps: list[dict[str, Any]]) -> dict[str, Any] | None:
    for row in steps:
        found = (row.get("policy") or {}).get("retrieval")
        if found is not None:
            return found
    return None


def first_refinement_entries(folder: Path) -> dict[str, int]:
    """Per "task/method" that was refined, the index of its memory's first refinement entry. Refinement appends
    its successes after the demos' entries, so in logs written before the retrieval record named the entry's
    source, an entry index at or past this one is a refinement rollout (from the folder's summary.json)."""
    summary = folder / "summary.json"
    records = (json.loads(summary.read_text()).get("refinement") or {}) if summary.is_file() else {}
    return {key: int(r["memory_entries"]) - int(r["inserted_into_memory"]) for key, r in records.items()
            if r.get("memory_entries") is not None and r.get("inserted_into_memory") is not None}


def retrieval_source(retrieval: dict[str, Any] | None, first_refinement: int | None, refined: bool) -> str:
    """Where the reference an episode followed came from: "demo" or "refinement" (the fired entry's source),
    "none" (no memory, or nothing above the threshold) or "unknown" (an older log of a refined method whose
    summary lacks the memory's size)."""
    if retrieval is None or not retrieval.get("fired") or retrieval.get("entry") is None:
        return "none"
    if retrieval.get("source"):
        return str(retrieval["source"])
    if not refined:
        return "demo"
    if first_refinement is None:
        return "unknown"
    return "refinement" if int(retrieval["entry"]) >= first_refinement else "demo"


def keyframe_shifts_cm(mine: list[dict[str, Any]], theirs: list[dict[str, Any]]) -> list[float]:
    """Per keyframe both episodes reached, the larger of the two arms' distances (cm) between the positions the
    two methods executed on the same seed."""
    return [round(100 * float(np.linalg.norm(np.asarray(a["executed"])[:, :3] - np.asarray(b["executed"])[:, :3],
                                             axis=-1).max()), 2) for a, b in zip(mine, theirs)]


def _keyframe_order(item: tuple[str, int]) -> tuple[bool, int]:
    return item[0] == "None", int(item[0]) if item[0] != "None" else 0


def _span(values: list[float]) -> list[float] | None:
    return [round(min(values), 2), round(max(values), 2)] if values else None


def against_rows(method_keys: list[tuple], episodes: dict[tuple, dict[str, Any]], logs: dict[tuple, list],
                 sources: dict[tuple, str], other: str) -> dict[str, Any]:
    """The method's episodes against ``other``'s on the same seeds, split by retrieval source: successes each, the
    episodes only the method won and only ``other`` won, how far apart the two executed first keyframes lie
    ([min, max] in cm), and the keyframe at which the two first part by more than the 3 cm tolerance (None: never
    within the keyframes both reached; later keyframes of a failing episode wander and say little)."""
    by_source: dict[str, dict[str, Any]] = {}
    for k in method_keys:
        theirs = (k[0], other, k[2], k[3])
        if theirs not in episodes or theirs not in logs:
            continue
        cell = by_source.setdefault(sources[k], {"episodes": 0, "successes": 0, "other_successes": 0, "won": 0,
                                                 "lost": 0, "first": [], "parted_at_keyframe": Counter()})
        ours_ok, theirs_ok = bool(episodes[k]["success"]), bool(episodes[theirs]["success"])
        cell["episodes"] += 1
        cell["successes"] += ours_ok
        cell["other_successes"] += theirs_ok
        cell["won"] += ours_ok and not theirs_ok
        cell["lost"] += theirs_ok and not ours_ok
        shifts = keyframe_shifts_cm(logs[k], logs[theirs])
        if shifts:
            cell["first"].append(shifts[0])
            parted = next((i for i, d in enumerate(shifts) if d > 100 * TOLERANCE_M), None)
            cell["parted_at_keyframe"][str(parted)] += 1
    for cell in by_source.values():
        cell["first_keyframe_shift_cm"] = _span(cell.pop("first"))
        cell["parted_at_keyframe"] = dict(sorted(cell["parted_at_keyframe"].items(), key=_keyframe_order))
    return {"method": other, "by_source": dict(sorted(by_source.items()))}


def explained_seeds(rows: list[dict[str, Any]]) -> dict[str, list[int]]:
    """The test seeds the rows of :func:`explain_rows` cover (a result file names its seeds)."""
    return {"test": sorted({int(s) for r in rows for s in r["seeds"]})}


def explain_rows(folder: str | Path, task: str, methods: list[str] | None = None, against: str | None = None,
                 perturbation: str | None = None) -> list[dict[str, Any]]:
    """One row per method of ``task`` in bench folder ``folder``: episodes, failures, the stages failures reached,
    where they first diverged (keyframe, arm), holds, the retrieval's firing rate and mean similarity, and the
    episodes by the source of the reference they retrieved (a demo or a refinement rollout) with their successes.
    With ``against``, each other method's episodes are also set against that method's on the same seeds; with
    ``perturbation``, only the episodes tested under it count."""
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder} is not a folder: give a bench or study run's result folder, the one "
                                "holding episodes.jsonl (e.g. results/table1/complex_tasks)")
    log = folder / KEYFRAME_LOG
    if not log.is_file() and log.with_suffix(".jsonl.gz").is_file():  # an archived folder keeps its log gzipped
        log = log.with_suffix(".jsonl.gz")
    if not log.is_file():
        raise FileNotFoundError(f"{folder} has no {KEYFRAME_LOG}: it was benchmarked before per-keyframe logs "
                                "existed; re-run its bench command (finished episodes are not redone, so delete "
                                "episodes.jsonl to log them)")
    episodes = {episode_key(e): e for e in read_records(folder / "episodes.jsonl")}
    logs = {episode_key(r): r["steps"] for r in read_records(log)}
    keys = [k for k in episodes if k[0] == task and k in logs]
    if perturbation is not None:
        recorded = sorted({k[2] for k in keys})
        keys = [k for k in keys if k[2] == perturbation]
        if recorded and not keys:
            raise ValueError(f"no logged episodes of {task!r} under perturbation {perturbation!r} in {folder}; "
                             f"logged perturbations: {', '.join(recorded)}")
    if not keys:
        known = sorted({k[0] for k in logs})
        raise ValueError(f"no logged episodes of {task!r} in {folder}; logged tasks: {known}")
    if methods:
        logged = list(dict.fromkeys(k[1] for k in keys))
        unknown = [m for m in methods if m not in logged]
        if unknown:
            raise ValueError(f"no logged episodes of {', '.join(unknown)} on {task!r} in {folder}; logged methods: "
                             f"{', '.join(logged)}")
        keys = [k for k in keys if k[1] in methods + ([against] if against else [])]
    if against and against not in {k[1] for k in keys}:
        raise ValueError(f"no logged episodes of {against} on {task!r} in {folder} to set the methods against")
    first_refinement = first_refinement_entries(folder)
    # refined: the summary records its refinement, or the registry says the method is refined
    sources = {k: retrieval_source(_retrieval(logs[k]), first_refinement.get(f"{k[0]}/{k[1]}"),
                                   f"{k[0]}/{k[1]}" in first_refinement
                                   or (k[1] in METHODS and get_method(k[1]).refine)) for k in keys}
    rows = []
    for method in dict.fromkeys(k[1] for k in keys):
        mine = [k for k in keys if k[1] == method]
        failed = [k for k in mine if not episodes[k]["success"]]
        failed_logs = [logs[k] for k in failed]
        success_logs = [logs[k] for k in mine if episodes[k]["success"]]
        divergences = {k: first_divergence(logs[k]) for k in failed}
        retrievals = [r for r in (_retrieval(logs[k]) for k in mine) if r is not None]
        # per arm and stage reached: [keyframes the arm was held, keyframes] (a waiting arm that never resumes
        # shows as a high share in the later stages)
        held_by_stage: dict[str, dict[int, list[int]]] = {}
        for k in mine:
            for row in logs[k]:
                for a in (row.get("policy") or {}).get("arms", []):
                    cell = held_by_stage.setdefault(a["arm"], {}).setdefault(int(row.get("stages_done", 0)), [0, 0])
                    cell[0] += int(bool(a.get("held", False)))
                    cell[1] += 1
        held = sum(h for stages in held_by_stage.values() for h, _ in stages.values())
        # per arm the expert leads with: [episodes the policy led with the same arm, episodes]
        leads: dict[str, list[int]] = {}
        for k in mine:
            pair = lead_arms(logs[k])
            if pair is not None:
                cell = leads.setdefault(pair[0], [0, 0])
                cell[0] += int(pair[0] == pair[1])
                cell[1] += 1
        rows.append({
            "method": method, "episodes": len(mine), "seeds": sorted({int(k[3]) for k in mine}),
            "failures": len(failed),
            "failed_at_stage": dict(sorted(Counter(episodes[k].get("stages_done", 0) for k in failed).items())),
            "first_divergence": dict(Counter(f"k{d.keyframe} {d.arm} ({d.what})" if d else "never (too slow)"
                                             for d in divergences.values()).most_common()),
            "failed_episodes": [{"seed": k[3], "stages_done": episodes[k].get("stages_done", 0),
                          "keyframes": episodes[k]["keyframes"],
                          "first_divergence": None if d is None else vars(d),
                          "first_keyframe_error_cm": first_keyframe_error_cm(logs[k]),
                          "retrieval_source": sources[k],
                          "retrieval_entry": (_retrieval(logs[k]) or {}).get("entry")} for k, d in divergences.items()],
            # the first keyframe is the one whose expert reference is always valid (later ones drift with the
            # episode), so it separates a bad start from a later slip
            "first_keyframe_cm": {"failures": first_keyframe_summary(failed_logs),
                                  "successes": first_keyframe_summary(success_logs)},
            "keyframe_profile": {"failures": keyframe_profile(failed_logs),
                                 "successes": keyframe_profile(success_logs)},
            # where the motion did not go where it was commanded (a contact, the arm's reach): the commanded
            # keyframe can match the expert's while the arm stops short of it
            "tracking_profile": {o: keyframe_profile(group, measured="reached", reference="executed")
                                 for o, group in (("failures", failed_logs), ("successes", success_logs))},
            "successes_first_divergence": dict(Counter(
                f"k{d.keyframe} {d.arm} ({d.what})" if d else "never"
                for d in (first_divergence(steps) for steps in success_logs)).most_common()),
            "held_arm_keyframes": held,
            "held_by_arm_and_stage": {arm: dict(sorted(v.items())) for arm, v in held_by_stage.items()},
            "same_lead_arm": dict(sorted(leads.items())),
            "retrieval_fired": (round(float(np.mean([r["fired"] for r in retrievals])), 3) if retrievals else None),
            "retrieval_similarity": (round(float(np.mean([r["similarity"] for r in retrievals
                                                          if r["similarity"] is not None])), 3)
                                     if retrievals else None),
            "by_retrieval_source": {source: {"episodes": sum(sources[k] == source for k in mine),
                                             "successes": sum(bool(episodes[k]["success"]) for k in mine
                                                              if sources[k] == source)}
                                    for source in sorted({sources[k] for k in mine})},
        })
        if against and method != against:
            rows[-1]["against"] = against_rows(mine, episodes, logs, sources, against)
    return rows


def explain_text(rows: list[dict[str, Any]], task: str) -> str:
    """The rows as a readable report."""
    lines = [f"# where failures happen: {task}", ""]
    for r in rows:
        lines.append(f"## {r['method']}: {r['failures']} of {r['episodes']} episodes failed")
        if r["failures"]:
            stages = ", ".join(f"stage {s}: {n}" for s, n in r["failed_at_stage"].items())
            lines.append(f"  stages reached by the failures: {stages}")
            lines.append("  first divergence from the expert (keyframe, arm, what):")
            lines += [f"    {n:3d} x {where}" for where, n in r["first_divergence"].items()]
            common = {where: n for where, n in r.get("successes_first_divergence", {}).items()
                      if where in r["first_divergence"]}
            if common:
                lines.append("  ... where the successes diverge first too: "
                             + ", ".join(f"{n} x {where}" for where, n in common.items()))
            profile = r.get("keyframe_profile") or {}
            for field, parting, reference in (
                    ("keyframe_profile", "failures part most from the successes", "the expert"),
                    ("tracking_profile", "the arms stop short of their command most apart from the successes",
                     "where they were sent")):
                found = r.get(field) or {}
                gap = widest_gap(found.get("failures") or {}, found.get("successes") or {})
                if gap:
                    unit = "cm" if gap["what"] == "position" else "degrees"
                    lines.append(f"  {parting} at k{gap['keyframe']} {gap['arm']} ({gap['what']}): median "
                                 f"{gap['failures']} against {gap['successes']} {unit} from {reference}")
            for arm in profile.get("failures") or {}:
                rows = {o: (profile.get(o) or {}).get(arm) or [] for o in ("failures", "successes")}
                cells = [f"k{k} " + " | ".join("-" if k >= len(rows[o]) or rows[o][k] is None
                                                else f"{rows[o][k][0]:g}/{rows[o][k][1]:.0f}"
                                                for o in ("failures", "successes"))
                         for k in range(max(len(v) for v in rows.values()))]
                lines.append(f"  {arm} from the expert per keyframe (cm/degrees, failures | successes): "
                             + ", ".join(cells))
        for outcome, cm in r["first_keyframe_cm"].items():
            if cm:
                lines.append(f"  first keyframe, {outcome} (median cm from the expert; residual added; prior turn: "
                             "degrees from the expert's): "
                             + ", ".join(f"{name} {v}" for name, v in cm.items()))
        if r["held_arm_keyframes"]:
            lines.append(f"  keyframes with an arm held: {r['held_arm_keyframes']}")
            for arm, stages in r["held_by_arm_and_stage"].items():
                shares = ", ".join(f"stage {st}: {h}/{n}" for st, (h, n) in stages.items())
                lines.append(f"    {arm} held, by stage reached: {shares}")
        if r.get("same_lead_arm"):
            agree = sum(a for a, _ in r["same_lead_arm"].values())
            total = sum(n for _, n in r["same_lead_arm"].values())
            by_arm = ", ".join(f"{arm} {a}/{n}" for arm, (a, n) in r["same_lead_arm"].items())
            lines.append(f"  moved first the arm the expert leads with: {agree}/{total} episodes "
                         f"(by the expert's lead arm: {by_arm})")
        if r["retrieval_fired"] is not None:
            lines.append(f"  retrieval fired in {100 * r['retrieval_fired']:.0f} % of episodes "
                         f"(mean nearest similarity {r['retrieval_similarity']})")
            by_source = ", ".join(f"{source} {c['successes']}/{c['episodes']}"
                                  for source, c in r["by_retrieval_source"].items())
            lines.append(f"  successes by the reference's source: {by_source}")
        if "against" in r:
            lines.append(f"  against {r['against']['method']} on the same seeds, by the reference's source:")
            for source, c in r["against"]["by_source"].items():
                first = c["first_keyframe_shift_cm"]
                parted = ", ".join(f"k{k}: {n}" if k != "None" else f"never: {n}"
                                   for k, n in c["parted_at_keyframe"].items())
                lines.append(f"    {source}: {c['episodes']} episodes, {c['successes']} vs {c['other_successes']} "
                             f"successes, {c['won']} won, {c['lost']} lost; first keyframes "
                             f"{first[0] if first else '-'}-{first[1] if first else '-'} cm apart; "
                             f"parted by > 3 cm at {parted}")
        lines.append("")
    return "\n".join(lines)
