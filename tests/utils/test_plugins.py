"""A user's own task and prior, in files outside the package, work through the CLI and in spawned workers."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

from bimanualshift.cli import main
from bimanualshift.utils.plugins import PLUGINS_ENV, PluginError, add_plugins, load_plugins

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "plugins"
TASK, PRIOR = str(EXAMPLES / "hammer_task.py"), str(EXAMPLES / "my_prior.py")


@pytest.fixture
def clean_plugin_env(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(PLUGINS_ENV, raising=False)


def test_a_user_task_and_prior_work_in_collect_pretrain_and_worker_processes(
        tmp_path: Path, clean_plugin_env: None, capsys: pytest.CaptureFixture[str]) -> None:
    main(["--plugin", TASK, "tasks"])
    assert "grasp_hammer" in capsys.readouterr().out  # its <asset> section compiled: robosuite's hammer materials
    main(["--plugin", TASK, "collect", "--task", "grasp_hammer", "--episodes", "3", "--out", str(tmp_path / "d"),
          "--image-size", "32"])
    assert len(list((tmp_path / "d" / "grasp_hammer").glob("*.h5"))) >= 2
    model = json.dumps({"voxel_size": 16, "patch_size": 4, "dim": 32, "num_latents": 8, "self_attention_layers": 1,
                        "heads": 2})
    main(["--plugin", TASK, "--plugin", PRIOR, "pretrain", "--prior", "peract_dropout", "--tasks", "grasp_hammer",
          "--data", str(tmp_path / "d"), "--validation-data", str(tmp_path / "d"), "--out", str(tmp_path / "p"),
          "--steps", "2", "--checkpoint-every", "2", "--model", model])
    config = json.loads((tmp_path / "p" / "best" / "config.json").read_text())
    assert config["type"] == "peract_dropout" and config["proprio_dropout"] == 0.1
    out = tmp_path / "report.json"
    # two spawned workers import both plugins (the task and the prior type) from the environment the command set
    main(["--plugin", TASK, "--plugin", PRIOR, "prior-report", "--prior", str(tmp_path / "p" / "best"),
          "--task", "grasp_hammer", "--episodes", "2", "--workers", "2", "--out", str(out)])
    (row,) = json.loads(out.read_text())["rows"]
    assert row["type"] == "peract_dropout" and row["tasks"]["grasp_hammer"]["episodes"] == 2


def test_entry_points_register_an_installed_package_task(tmp_path: Path, clean_plugin_env: None,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    from bimanualshift.sim.task import TASKS
    from bimanualshift.sim.task_registry import task_names

    site = tmp_path / "site"
    (site / "my_tasks_pkg").mkdir(parents=True)
    (site / "my_tasks_pkg" / "__init__.py").write_text(
        "from bimanualshift.sim.tasks.unimanual.push_button import PushButton\n"
        "from bimanualshift.sim.task import register_task\n\n\n"
        "@register_task('push_button_again')\nclass PushButtonAgain(PushButton):\n    pass\n")
    info = site / "my_tasks_pkg-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my-tasks-pkg\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[bimanualshift.tasks]\nmine = my_tasks_pkg\n")
    monkeypatch.syspath_prepend(str(site))
    try:
        assert "push_button_again" in task_names()
    finally:
        TASKS.pop("push_button_again", None)
        sys.modules.pop("my_tasks_pkg", None)


def test_a_missing_or_broken_plugin_is_named(tmp_path: Path, clean_plugin_env: None) -> None:
    with pytest.raises(PluginError, match="no plugin module 'no_such_module_here'"):
        add_plugins(["no_such_module_here"])
    os.environ.pop(PLUGINS_ENV)
    broken = tmp_path / "broken.py"
    broken.write_text("raise RuntimeError('boom')\n")
    with pytest.raises(SystemExit, match="broken.py failed to import: RuntimeError: boom"):
        main(["--plugin", str(broken), "tasks"])
    os.environ.pop(PLUGINS_ENV)
    assert load_plugins() == []
