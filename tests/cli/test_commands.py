import argparse

import pytest

from bimanualshift.cli import build_parser, main


def _commands() -> list[str]:
    subparsers = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sorted(subparsers.choices)


@pytest.mark.parametrize("command", _commands())
def test_every_subcommand_has_help(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main([command, "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "usage: bimanualshift " + command in out
    assert "type: ignore" not in out  # a type checker's marker in a trailing comment would become help text


def test_top_level_help_lists_the_flow() -> None:
    assert "bimanualshift demo" in build_parser().format_help()


def test_collect_rejects_unknown_task() -> None:
    with pytest.raises(SystemExit, match="unknown task"):
        main(["collect", "--task", "nope", "--episodes", "1", "--out", "/tmp/x"])


@pytest.mark.slow
def test_deploy_names_a_server_it_cannot_reach() -> None:
    with pytest.raises(SystemExit, match="cannot reach the policy server at ws://127.0.0.1:1: .*bimanualshift serve"):
        main(["deploy", "--robot", "sim", "--task", "push_two_buttons", "--server", "ws://127.0.0.1:1", "--episodes",
              "1"])


def test_deploy_refuses_a_chunk_of_no_keyframes_before_connecting() -> None:
    with pytest.raises(SystemExit, match="--chunk-steps 0: give 1"):
        main(["deploy", "--chunk-steps", "0", "--server", "ws://127.0.0.1:1", "--episodes", "1"])


def test_train_rejects_unknown_config_keys(tmp_path) -> None:  # noqa: ANN001
    cfg = tmp_path / "c.json"
    cfg.write_text('{"stepz": 3}')
    with pytest.raises(SystemExit, match="unknown keys \\['stepz'\\]"):
        main(["train", "--config", str(cfg)])


def test_experts_writes_a_result_file(tmp_path) -> None:  # noqa: ANN001
    import json

    out = tmp_path / "experts.json"
    main(["experts", "--task", "pick_up_plate", "--episodes", "1", "--out", str(out)])
    result = json.loads(out.read_text())
    (row,) = result["rows"]
    assert row["task"] == "pick_up_plate" and row["episodes"] == 1 and row["success"] == 1.0
    assert result["command"].startswith("bimanualshift") and result["seeds"]["test"]
    with pytest.raises(SystemExit, match="unknown task"):
        main(["experts", "--task", "nope", "--episodes", "1"])


def test_experts_run_under_each_perturbation_asked_for(tmp_path) -> None:  # noqa: ANN001
    import json

    out = tmp_path / "experts.json"
    main(["experts", "--task", "block_threading", "--episodes", "1", "--perturb", "none", "unseen_shapes",
          "--out", str(out)])
    rows = json.loads(out.read_text())["rows"]
    assert [(r["task"], r["perturbation"], r["episodes"]) for r in rows] == [
        ("block_threading", "none", 1), ("block_threading", "unseen_shapes", 1)]
    with pytest.raises(SystemExit):
        main(["experts", "--task", "block_threading", "--episodes", "1", "--perturb", "sunset"])


def test_task_groups_resolve_to_registered_tasks() -> None:
    from bimanualshift.cli.common import resolve_tasks
    from bimanualshift.sim.task import TASKS
    from bimanualshift.sim.task_registry import task_names

    assert resolve_tasks(["bimanual"]) == task_names(bimanual=True, robot="panda")
    assert resolve_tasks(["unimanual", "lift_ball"]) == [*task_names(bimanual=False, robot="panda"), "lift_ball"]
    realworld = resolve_tasks(["realworld"])  # the paper's real-world tasks: bimanual, built for the twin
    assert {"block_threading", "vegetable_sorting", "toaster_activation", "serve_toast"} <= set(realworld)
    assert all(TASKS[t].bimanual and TASKS[t].robot == "ur5e" for t in realworld)
    assert "push_button@ur5e" in resolve_tasks(["unimanual_ur5e"])
    with pytest.raises(SystemExit, match="one of the groups all, bimanual, unimanual, .*realworld"):
        main(["experts", "--task", "bimanul", "--episodes", "1"])


def test_video_records_the_expert(tmp_path) -> None:  # noqa: ANN001
    import imageio.v3 as iio

    main(["video", "--task", "pick_up_plate", "--out", str(tmp_path), "--image-size", "32", "--every", "5",
          "--cameras", "front"])
    frames = iio.imread(tmp_path / "pick_up_plate.mp4")
    assert frames.shape[0] > 10 and frames.shape[1:] == (32, 32, 3)
    assert frames[0].astype(int).sum() != frames[-1].astype(int).sum()  # the scene moved


def test_a_saved_config_reproduces_the_run_and_flags_override_it(tmp_path) -> None:  # noqa: ANN001
    import json
    from dataclasses import asdict

    from bimanualshift.cli.dispatch import parse_command
    from bimanualshift.training.configs import TrainConfig
    from bimanualshift.utils.config_files import config_from_flat

    saved = config_from_flat(TrainConfig, task="lift_ball", steps=7, retrieval=True, lr=0.01)
    path = tmp_path / "train_config.json"
    path.write_text(json.dumps(asdict(saved)))  # what `train` writes beside its run
    _, cfg = parse_command("train", ["--config", str(path)])
    assert cfg == saved
    _, cfg = parse_command("train", ["--config", str(path), "--steps", "9", "--retrieval", "false"])
    assert cfg.optim.steps == 9 and not cfg.model.retrieval and cfg.dataset.task == "lift_ball"


def test_a_reader_closing_the_pipe_stops_the_command_quietly() -> None:
    import subprocess
    import sys

    # `bimanualshift tasks | head -1`: the reader goes after one line; no traceback, the SIGPIPE exit status
    code = ("import sys; sys.stdout = open(sys.stdout.fileno(), 'w', buffering=1, closefd=False); "
            "from bimanualshift.cli import main; main(['tasks'])")
    done = subprocess.run(f"{sys.executable} -c \"{code}\" | head -c 1", shell=True, capture_output=True, text=True,
                          executable="/bin/bash")
    assert "Traceback" not in done.stderr and "BrokenPipe" not in done.stderr
