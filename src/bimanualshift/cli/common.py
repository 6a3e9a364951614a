"""What several commands share: task names from the command line, the command line itself for result files."""

from __future__ import annotations

import shlex
import sys


def resolve_tasks(requested: list[str]) -> list[str]:
    """Task names from --task: registered names or groups (all, bimanual, unimanual, realworld, ...; a clear error
    otherwise)."""
    from bimanualshift.sim.task_registry import resolve_task_names

    return resolve_task_names(requested)


def command_line() -> str:
    """This invocation as a result file records it: ``bimanualshift`` and its arguments."""
    return " ".join(["bimanualshift", *(shlex.quote(a) for a in sys.argv[1:])])
