"""`bench --rerun METHOD` (or `TASK/METHOD`): run methods of a results folder again from scratch, keeping what
they replace.

After a change to a method its recorded episodes are stale, and so is its training run, which a resumed benchmark
would otherwise reuse. ``supersede`` moves both aside: the method's episodes, per-keyframe logs, videos and
run records to ``<out>/superseded/<method>-<commit>/``, its training runs to
``<runs>/<task>/superseded/<folder>-<commit>/``. The archive folder is written last and marks the re-run as
started at that commit, so repeating the same command after a kill resumes the re-run instead of discarding
its new episodes; a later commit supersedes again. A step cut short by a kill is redone without losing records.

``TASK/METHOD`` re-runs one task of a method: what a session cut off in the middle of that task's test episodes
leaves to redo when its training run is gone (a fresh checkout), without retraining the tasks it finished. Its
archive is ``<method>-<task>-<commit>``.
"""

from __future__ import annotations

import gzip
import json
import shutil
from pathlib import Path
from typing import Any

from bimanualshift.registry import METHODS, REFINE_FOLDER, get_method
from bimanualshift.sim.task_registry import task_names
from bimanualshift.utils.io import atomic_write_json, atomic_writer
from bimanualshift.utils.jsonl import read_records

RECORD_LOGS = ("episodes.jsonl", "keyframes.jsonl")  # a results folder's logs, one record per episode
SUMMARY_RECORDS = ("training", "refinement")  # summary.json's per "task/method" records of the runs behind it
SUPERSEDED = "superseded"


def run_folders(method: str, runs: str | Path, tasks: list[str]) -> list[Path]:
    """The training-run folders a re-run of ``method`` must not reuse: a variant that refines another method's
    run differently gives up its own refinement folder only; any other method its whole run."""
    spec = get_method(method)
    own = spec.run_name if spec.refine_folder == REFINE_FOLDER else f"{spec.run_name}/{spec.refine_folder}"
    return [Path(runs) / task / own for task in tasks]


def sharing_methods(method: str) -> list[str]:
    """Registered methods whose results come from ``method``'s training run too (the full method, its unrefined
    row, its refinement variants), so retraining it changes theirs."""
    spec = get_method(method)
    if spec.refine_folder != REFINE_FOLDER:
        return []
    return [m for m, s in METHODS.items() if m != method and s.run_name == spec.run_name]


def _archive_name(method: str, commit: str) -> str:
    return f"{method}-{commit[:12]}{'-dirty' if commit.endswith('-dirty') else ''}"


def split_entry(entry: str) -> tuple[str | None, str]:
    """A ``--rerun`` entry as (task or None for every task, method)."""
    task, _, method = entry.rpartition("/")
    return task or None, method


def _episode(record: dict[str, Any]) -> tuple[str, str, str, int]:
    return record["task"], record["method"], record.get("perturbation", "none"), record["seed"]


def check_rerun(rerun: list[str], methods: list[str], out: str | Path) -> None:
    """A clear error before anything moves: every re-run method is benchmarked in this run, every named task is
    registered, and no recorded method shares a training run that the re-run would replace."""
    known = task_names()
    unknown = [e for e in rerun if split_entry(e)[1] not in methods]
    if unknown:
        raise ValueError(f"--rerun {' '.join(unknown)}: not among --methods ({' '.join(methods)}); a re-run method "
                         "is run again, so list it in --methods too")
    no_task = [e for e in rerun if split_entry(e)[0] not in (None, *known)]
    if no_task:
        raise ValueError(f"--rerun {' '.join(no_task)}: no such task; give METHOD or TASK/METHOD with a task of "
                         f"`bimanualshift tasks` ({', '.join(known)})")
    records = read_records(Path(out) / "episodes.jsonl")
    for entry in rerun:
        task, method = split_entry(entry)
        recorded = {e["method"] for e in records if task is None or e["task"] == task}
        left = [m for m in sharing_methods(method) if m in recorded and m not in rerun
                and (task is None or f"{task}/{m}" not in rerun)]
        if left:
            again = " ".join(left if task is None else [f"{task}/{m}" for m in left])
            raise ValueError(f"--rerun {entry} retrains the run that {', '.join(left)} also come from, whose "
                             f"episodes are recorded in {out}; add {again} to --rerun")


def supersede(method: str, out: str | Path, runs: str | Path, tasks: list[str], commit: str,
              task: str | None = None) -> Path | None:
    """Move ``method``'s records in ``out`` and its runs under ``runs`` into archives named by ``commit`` (with
    ``task``, that task's alone); returns the archive, or None when a re-run at this commit has already started (it
    is resumed)."""
    out = Path(out)
    tasks = tasks if task is None else [task]
    archive = out / SUPERSEDED / _archive_name(method if task is None else f"{method}-{task}", commit)

    def mine(record: dict[str, Any]) -> bool:
        return record.get("method") == method and (task is None or record.get("task") == task)
    if archive.is_dir():
        return None
    partial = archive.with_name(archive.name + ".partial")  # renamed to ``archive`` once everything is moved
    partial.mkdir(parents=True, exist_ok=True)
    for name in RECORD_LOGS:
        log = out / name
        records = read_records(log)
        moved = [r for r in records if mine(r)]
        saved = partial / f"{name}.gz"
        if moved:
            # a kill between saving and rewriting the log saved some of them already: one record per episode
            merged = {_episode(r): r for r in read_records(saved) + moved}
            text = "".join(json.dumps(r) + "\n" for r in merged.values())
            with atomic_writer(saved) as tmp:
                tmp.write_bytes(gzip.compress(text.encode(), mtime=0))
            with atomic_writer(log) as tmp:
                tmp.write_text("".join(json.dumps(r) + "\n" for r in records if not mine(r)))
    summary = out / "summary.json"
    if summary.is_file():
        fields = json.loads(summary.read_text())
        kept = {f: {k: v for k, v in (fields.get(f) or {}).items()
                    if k.split("/")[-1] == method and (task is None or k.split("/")[0] == task)}
                for f in SUMMARY_RECORDS}
        if any(kept.values()):
            atomic_write_json(partial / "records.json", kept)
    for video in sorted((out / "videos").glob("*.mp4")):
        if any(video.name.startswith(f"{task}_{method}_") for task in tasks):
            (partial / "videos").mkdir(exist_ok=True)
            shutil.move(video, partial / "videos" / video.name)
    for folder in run_folders(method, runs, tasks):
        if folder.is_dir():
            target = _free(folder.parent / SUPERSEDED / _archive_name(folder.name, commit))
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.move(folder, target)
    partial.rename(archive)
    return archive


def _free(path: Path) -> Path:
    """``path``, or ``path-2``, ``path-3``... if it is taken (a method superseded twice at one commit)."""
    candidate, n = path, 1
    while candidate.exists():
        n += 1
        candidate = path.with_name(f"{path.name}-{n}")
    return candidate


def supersede_all(rerun: list[str], methods: list[str], out: str | Path, runs: str | Path, tasks: list[str],
                  commit: str) -> list[dict[str, Any]]:
    """Check, then supersede every re-run method; one line per method saying what happened."""
    check_rerun(rerun, methods, out)
    report = []
    for entry in rerun:
        task, method = split_entry(entry)
        if task is not None and task not in tasks:
            continue  # a study's other half holds that task
        archive = supersede(method, out, runs, tasks, commit, task)
        report.append({"method": entry, "archive": str(archive) if archive else None})
        if archive:
            print(f"[bench] --rerun {entry}: its earlier episodes, logs and runs moved to {archive} and "
                  f"{Path(runs)}/{task or '<task>'}/{SUPERSEDED}/")
        else:
            print(f"[bench] --rerun {entry}: a re-run at commit {commit[:12]} has already started; resuming it")
    return report
