"""A command cut off by its reader (``| head``) ends with status 141 and no traceback; every benchmark script's
entry point goes through the same guard as the CLI."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

from bimanualshift.utils.pipes import CLOSED_PIPE_STATUS

ROOT = Path(__file__).resolve().parents[2]
WRITER = """
from bimanualshift.utils.pipes import quiet_on_closed_pipe
with quiet_on_closed_pipe():
    for i in range(200000):
        print("row", i)
"""


def test_a_closed_pipe_ends_quietly_with_status_141() -> None:
    writer = subprocess.Popen([sys.executable, "-c", WRITER], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert writer.stdout is not None and writer.stderr is not None
    assert writer.stdout.readline() == b"row 0\n"
    writer.stdout.close()  # the reader goes away, as `head` does
    status, stderr = writer.wait(timeout=60), writer.stderr.read().decode()
    assert status == CLOSED_PIPE_STATUS and "Traceback" not in stderr and "BrokenPipeError" not in stderr


def test_without_the_guard_the_same_writer_raises() -> None:
    bare = WRITER.replace("with quiet_on_closed_pipe():\n    for", "if True:\n    for")
    writer = subprocess.Popen([sys.executable, "-c", bare], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert writer.stdout is not None and writer.stderr is not None
    writer.stdout.readline()
    writer.stdout.close()
    assert writer.wait(timeout=60) != 0 and "BrokenPipeError" in writer.stderr.read().decode()


def test_every_benchmark_runs_main_under_the_guard() -> None:
    for script in sorted((ROOT / "benchmarks").glob("*.py")):
        tree = ast.parse(script.read_text())
        entry = [node for node in tree.body if isinstance(node, ast.If) and "__main__" in ast.unparse(node.test)]
        assert entry, f"{script.name} has no `if __name__ == '__main__'` entry point"
        assert "with quiet_on_closed_pipe():" in ast.unparse(entry[0]), script.name
