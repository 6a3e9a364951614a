"""Every committed result file's command still runs: a `bimanualshift ...` command parses with today's flags, and a
benchmark script it names exists (a script moved to benchmarks/investigations/ takes its result files along)."""

from __future__ import annotations

import contextlib
import io
import json
import re
import shlex
from pathlib import Path

from bimanualshift.cli.dispatch import parse_command

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = re.compile(r"benchmarks/[\w/]+\.py")


def recorded_commands() -> list[tuple[str, str]]:
    """(result file, command) for every result file, superseded runs' included."""
    found = []
    for path in sorted((ROOT / "results").rglob("*.json")):
        try:
            result = json.loads(path.read_text())
        except (UnicodeDecodeError, json.JSONDecodeError):
            continue
        if isinstance(result, dict) and isinstance(result.get("command"), str):
            for command in re.split(r";|\n", result["command"]):
                found.append((str(path.relative_to(ROOT)), command.split(" #")[0].strip()))
    return found


def test_every_result_files_command_still_runs() -> None:
    commands = recorded_commands()
    assert len(commands) > 50
    broken = [(f, s) for f, c in commands for s in SCRIPT.findall(c) if not (ROOT / s).is_file()]
    for file, command in commands:
        if not command.startswith("bimanualshift "):
            continue
        argv = shlex.split(command)[1:]
        while argv and argv[0] == "--plugin":
            argv = argv[2:]
        try:
            with contextlib.redirect_stderr(io.StringIO()):
                parse_command(argv[0], argv[1:])
        except SystemExit:
            broken.append((file, command))
    assert not broken, f"result files whose commands no longer run: {broken[:5]}"
