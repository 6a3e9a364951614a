"""Cells two benchmark folders have in common, recorded once.

Two studies may plan the same cell: Fig. 11a's 15-demo half on the twin is Table II's vegetable sorting and block
threading, from the same models (one runs folder), settings and test seeds. An episode has one outcome
(`tests/evaluation/test_bench.py`), so rolling those cells out again would only cost hours. A run given
``share_from`` copies the other folder's recorded episodes of its own tasks, methods, perturbations and seeds (and
their per-keyframe log lines and videos) into its folder, after checking that they were made under the same
settings from the same runs and demos; it then rolls out only what is still missing, as a resumed run does.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from bimanualshift.evaluation.stats import episode_key
from bimanualshift.utils.jsonl import append_record, read_records

# the folder fields a shared run must have in common with this one besides its episode settings: the models
# (runs) and demos (data) behind its episodes
SAME_FOLDERS = ("runs", "data")


def check_shareable(source: Path, settings: dict[str, Any], folders: dict[str, str], settings_file: str) -> None:
    """Refuse a source folder whose episodes were made under other settings, runs or demos than this run's."""
    if not (source / "episodes.jsonl").is_file():
        raise FileNotFoundError(f"share_from={str(source)!r} holds no episodes.jsonl: run that benchmark first, "
                                "or drop share_from")
    if not (source / settings_file).is_file():
        raise ValueError(f"share_from={str(source)!r} has no {settings_file}, so its settings cannot be checked: "
                         "re-tabulate it with today's bench first, or drop share_from")
    theirs = json.loads((source / settings_file).read_text())
    config = json.loads((source / "summary.json").read_text()).get("config", {}) \
        if (source / "summary.json").is_file() else {}
    differ = {k: (theirs.get(k), v) for k, v in settings.items() if theirs.get(k) != v}
    differ |= {k: (config.get(k), v) for k, v in folders.items() if config.get(k) != v}
    if differ:
        listed = "; ".join(f"{k}={old!r} there, {new!r} here" for k, (old, new) in differ.items())
        raise ValueError(f"share_from={str(source)!r} was recorded under other settings ({listed}): its episodes "
                         "are not this run's; drop share_from to roll them out here")


def share_recorded(source: Path, out: Path, wanted: Iterable[tuple[str, str, str, int]], keyframe_log: str
                   ) -> int:
    """Copy ``source``'s recorded episodes among ``wanted`` that ``out`` lacks, with their keyframe-log lines and
    videos; returns how many were copied. Each copy is appended and synced like a finished rollout."""
    wanted = set(wanted)
    have = {episode_key(e) for e in read_records(out / "episodes.jsonl")}
    theirs = [e for e in read_records(source / "episodes.jsonl") if episode_key(e) in wanted - have]
    if not theirs:
        return 0
    keys = {episode_key(e) for e in theirs}
    for line in read_records(source / keyframe_log):
        if episode_key(line) in keys:
            append_record(out / keyframe_log, line)
    for episode in theirs:
        append_record(out / "episodes.jsonl", episode)
    (out / "videos").mkdir(parents=True, exist_ok=True)
    names = {f"{t}_{m}{'' if p == 'none' else f'_{p}'}_{s}.mp4" for t, m, p, s in keys}  # bench's video names
    for video in sorted((source / "videos").glob("*.mp4")):
        if video.name in names and not (out / "videos" / video.name).exists():
            shutil.copyfile(video, out / "videos" / video.name)
    return len(theirs)


def count_shared(source: Path, episodes: list[dict[str, Any]]) -> int:
    """How many of ``episodes`` are the source's own records (same key and actions), for the summary."""
    theirs = {episode_key(e): e.get("actions_sha256") for e in read_records(source / "episodes.jsonl")}
    return sum(1 for e in episodes if theirs.get(episode_key(e), "-") == e.get("actions_sha256"))


def shared_records(source: Path, field: str, pairs: set[str]) -> dict[str, dict[str, Any]]:
    """The source summary's ``field`` records (training, refinement) of the "task/method" pairs shared from it:
    the runs behind them are the same, and runs/ is not committed."""
    summary = source / "summary.json"
    records = (json.loads(summary.read_text()).get(field) or {}) if summary.is_file() else {}
    return {k: v for k, v in records.items() if k in pairs}
