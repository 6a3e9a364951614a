import pytest

from bimanualshift.cli import build_parser, main


@pytest.mark.parametrize("command", ["experts", "snapshot", "collect", "pretrain", "train", "eval", "demo", "tasks"])
def test_every_subcommand_has_help(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main([command, "--help"])
    assert exc.value.code == 0
    assert "usage: bimanualshift " + command in capsys.readouterr().out


def test_top_level_help_lists_the_flow() -> None:
    assert "bimanualshift demo" in build_parser().format_help()


def test_collect_rejects_unknown_task() -> None:
    with pytest.raises(SystemExit, match="unknown task"):
        main(["collect", "--task", "nope", "--episodes", "1", "--out", "/tmp/x"])


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
