"""Task lookup lives apart from the task hooks: importing ``sim.task`` (what every task file imports) loads no
task, and the first lookup registers them all."""

from __future__ import annotations

import subprocess
import sys


def test_the_task_hooks_import_no_task_and_lookup_registers_them() -> None:
    code = ("import sys; import bimanualshift.sim.task as t; "
            "assert not [m for m in sys.modules if m.startswith('bimanualshift.sim.tasks')], 'a task was imported'; "
            "assert not t.TASKS; "
            "from bimanualshift.sim.task_registry import task_names; assert 'push_two_buttons' in task_names()")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
