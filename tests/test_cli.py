import pytest

from bimanualshift.cli import build_parser, main


@pytest.mark.parametrize("command", ["collect", "pretrain", "train", "eval", "demo", "tasks"])
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
