"""Result files (the envelope of docs/results-format.md) and readable tables."""

from __future__ import annotations

import platform
import shlex
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from bimanualshift import __version__
from bimanualshift.evaluation.stats import SuccessRate, SuccessRow
from bimanualshift.rollout.loop import EpisodeRecord
from bimanualshift.utils.io import atomic_write_json


def git_commit(since: float | None = None, cwd: Path | None = None) -> str:
    """The commit the code runs from (``-dirty`` when code or configuration changed), or, for an installed
    package outside a git checkout, ``version-<package version>``.

    ``since`` (a start time): the commit the checkout stood at then, the newest on HEAD's history made by that
    time. A long run outlives the commits made while it runs; its code is the one it started from."""
    cwd = cwd or Path(__file__).resolve().parent
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, check=True,
                              cwd=cwd).stdout.strip()
        if since is not None:
            moment = datetime.fromtimestamp(since, timezone.utc).isoformat(timespec="seconds")
            then = subprocess.run(["git", "rev-list", "-1", f"--before={moment}", "HEAD"], capture_output=True,
                                  text=True, check=True, cwd=cwd).stdout.strip()
            if then and then != head:
                return then  # the checkout has moved on since; whether it was dirty then is not known
        # Changed code or configuration marks the commit dirty; result files a run rewrites do not.
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ":/", ":!/results"],
                               capture_output=True, text=True, cwd=cwd).stdout.strip()
        return head + ("-dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return f"version-{__version__}"


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import os

    import torch  # here, not at the top: scripts that only tabulate episodes start 1.7 s sooner without it

    return f"{cpu}, {os.cpu_count()} cores, torch {torch.__version__}, python {sys.version.split()[0]}"


def success_rows(records: list[EpisodeRecord], **extra: Any) -> list[dict[str, Any]]:
    rows = []
    for method in dict.fromkeys(r.method for r in records):
        for task in dict.fromkeys(r.task for r in records):
            mine = [r for r in records if r.method == method and r.task == task]
            if not mine:
                continue
            rows.append(SuccessRow(task, method, SuccessRate.of(r.success for r in mine), context=extra,
                                   details={"mean_keyframes": round(float(np.mean([r.keyframes for r in mine])), 2)}
                                   ).to_dict())
    return rows


def invoked_command(argv: list[str] | None = None) -> str:
    """The command line a script was run with (``sys.argv``), quoted so that a reader can paste it back, for a
    result file's ``command``."""
    argv = list(sys.argv if argv is None else argv)
    script = Path(argv[0])
    if script.is_absolute():  # a path under the working directory is written as the reader would type it
        try:
            script = script.relative_to(Path.cwd())
        except ValueError:
            pass
    return shlex.join(["python", str(script), *argv[1:]])


def threads() -> dict[str, Any]:
    """The threads a result ran with: torch's intra-op count in the writing process (workers run on one), and the
    count every policy forward pass is pinned to whatever the process's (``core.threads``)."""
    import torch

    from bimanualshift.core.threads import POLICY_THREADS

    return {"process": torch.get_num_threads(), "policy_forward": POLICY_THREADS}


def write_result(path: str | Path, command: str, seeds: dict[str, list[int]], started: float,
                 rows: list[dict[str, Any]], notes: str = "", **extra: Any) -> Path:
    atomic_write_json(path, {
        "command": command, "commit": git_commit(since=started),
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"), "machine": machine(),
        "seeds": seeds, "threads": threads(), "wall_time_s": round(time.time() - started, 1), "rows": rows,
        "notes": notes, **extra,
    })
    return Path(path)


