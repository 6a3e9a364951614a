"""Result-file envelope helpers."""

from __future__ import annotations

import subprocess
from pathlib import Path
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


def test_a_run_is_credited_to_the_commit_it_started_from(tmp_path: Path) -> None:
    from bimanualshift.evaluation.report import git_commit

    def git(*args: str, when: int | None = None) -> str:
        env = {"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t",
               "GIT_COMMITTER_EMAIL": "t@t", "PATH": "/usr/bin:/bin"}
        if when is not None:
            env |= {"GIT_AUTHOR_DATE": f"@{when} +0000", "GIT_COMMITTER_DATE": f"@{when} +0000"}
        return subprocess.run(["git", *args], cwd=tmp_path, env=env, capture_output=True, text=True,
                              check=True).stdout.strip()

    git("init", "-q")
    (tmp_path / "a.py").write_text("1\n")
    git("add", "a.py")
    git("commit", "-qm", "first", when=1_700_000_000)
    first = git("rev-parse", "HEAD")
    (tmp_path / "a.py").write_text("2\n")
    git("commit", "-qam", "second", when=1_700_000_100)  # made while the run went on
    second = git("rev-parse", "HEAD")
    assert git_commit(since=1_700_000_050, cwd=tmp_path) == first
    assert git_commit(since=1_700_000_200, cwd=tmp_path) == second
    (tmp_path / "a.py").write_text("3\n")
    assert git_commit(cwd=tmp_path) == second + "-dirty"
