"""Result-file envelope helpers."""

from __future__ import annotations

import subprocess
from typing import Any

import pytest

from bimanualshift import __version__
from bimanualshift.evaluation import report


def test_git_commit_inside_the_checkout_names_a_commit() -> None:
    commit = report.git_commit()
    if commit.startswith("version-"):
        pytest.skip("the tests run outside a git checkout")
    assert len(commit.removesuffix("-dirty")) == 40


def test_git_commit_outside_a_checkout_names_the_package_version(monkeypatch: pytest.MonkeyPatch) -> None:
    def no_git(*args: Any, **kwargs: Any) -> None:
        raise subprocess.CalledProcessError(128, "git rev-parse HEAD")

    monkeypatch.setattr(report.subprocess, "run", no_git)
    assert report.git_commit() == f"version-{__version__}"


def test_invoked_command_can_be_pasted_back(monkeypatch: pytest.MonkeyPatch, tmp_path: Any) -> None:
    import shlex

    monkeypatch.chdir(tmp_path)
    argv = [str(tmp_path / "benchmarks" / "speed.py"), "--tasks", "lift tray", "--out", "results/a b.json"]
    command = report.invoked_command(argv)
    assert command.startswith("python benchmarks/speed.py ")  # under the working directory: as typed there
    assert shlex.split(command) == ["python", "benchmarks/speed.py", *argv[1:]]
    assert shlex.split(report.invoked_command(["/elsewhere/x.py", "--n", "3"])) == ["python", "/elsewhere/x.py",
                                                                                   "--n", "3"]
