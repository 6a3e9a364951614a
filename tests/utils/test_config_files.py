"""Loading names the file, the field, what was expected and the fix (never a library's bare message)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bimanualshift.priors.base import UnimanualPrior, build_prior
from bimanualshift.utils.config_files import CheckpointError


@pytest.fixture
def prior_dir(tmp_path: Path) -> Path:
    return build_prior("peract", "debug").save_pretrained(tmp_path / "prior")


def test_a_truncated_weights_file_is_named_with_the_fix(prior_dir: Path) -> None:
    weights = prior_dir / "model.safetensors"
    weights.write_bytes(weights.read_bytes()[:5])
    with pytest.raises(CheckpointError, match=rf"{weights} \(5 bytes\) is not a readable safetensors file.*truncated"):
        UnimanualPrior.from_pretrained(prior_dir)


def test_a_config_value_of_the_wrong_type_names_the_file_and_field(prior_dir: Path) -> None:
    path = prior_dir / "config.json"
    path.write_text(json.dumps({**json.loads(path.read_text()), "dim": "abc"}))
    with pytest.raises(CheckpointError, match=rf"{path}: field 'dim' is 'abc' \(str\), expected int; correct it"):
        UnimanualPrior.from_pretrained(prior_dir)


def test_a_config_that_is_not_json_is_named(prior_dir: Path) -> None:
    path = prior_dir / "config.json"
    path.write_text('{"type": "peract",')
    with pytest.raises(CheckpointError, match=rf"{path} is not valid JSON"):
        UnimanualPrior.from_pretrained(prior_dir)


def test_the_command_line_prints_one_error_line_and_exits_2(prior_dir: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    from bimanualshift.cli import main

    (prior_dir / "model.safetensors").write_bytes(b"\x00" * 3)
    with pytest.raises(SystemExit) as exc:
        main(["eval", "--method", "prior", "--prior", str(prior_dir), "--task", "push_button", "--episodes", "1"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "model.safetensors" in errors[0] and "Traceback" not in err


def test_a_flat_config_of_an_older_run_reads_as_the_nested_one() -> None:
    from dataclasses import asdict

    from bimanualshift.training.configs import PretrainConfig, TrainConfig
    from bimanualshift.utils.config_files import config_from_dict

    flat = {"task": "lift_ball", "data": "d", "steps": 7, "retrieval": True, "prior": "p", "lr": 0.1, "beta": 2.0}
    cfg = config_from_dict(TrainConfig, flat, "old.json", ignore_unknown=False)
    assert (cfg.dataset.task, cfg.dataset.data, cfg.optim.steps, cfg.optim.lr) == ("lift_ball", "d", 7, 0.1)
    assert cfg.model.retrieval and cfg.prior == "p" and cfg.beta == 2.0
    assert config_from_dict(TrainConfig, json.loads(json.dumps(asdict(cfg))), "new.json") == cfg
    old_prior = {"prior": "dp", "tasks": ["push_button"], "model": {"dim": 64}, "steps": 5, "size": "debug"}
    pretrain = config_from_dict(PretrainConfig, old_prior, "old.json", ignore_unknown=False)
    assert pretrain.network.model == {"dim": 64} and pretrain.network.prior == "dp" and pretrain.optim.steps == 5
    with pytest.raises(CheckpointError, match=r"old.json \(optim\): field 'steps' is 'many'"):
        config_from_dict(TrainConfig, {**flat, "steps": "many"}, "old.json")


def test_a_flat_key_keeps_the_parents_defaults_for_the_rest_of_its_group() -> None:
    from bimanualshift.training.configs import PretrainConfig, TrainConfig
    from bimanualshift.utils.config_files import config_from_flat

    # naming one optimiser field must not reset the others to OptimConfig's generic defaults
    residual = config_from_flat(TrainConfig, task="lift_ball", steps=7)
    assert residual.optim.steps == 7
    assert (residual.optim.lr, residual.optim.schedule) == (TrainConfig().optim.lr, TrainConfig().optim.schedule)
    pretrain = config_from_flat(PretrainConfig, lr=3e-4)
    assert pretrain.optim.lr == 3e-4 and pretrain.optim.steps == PretrainConfig().optim.steps


def test_a_missing_config_names_the_folder_and_what_is_missing(tmp_path: Path) -> None:
    from bimanualshift.utils.config_files import read_json_file

    with pytest.raises(FileNotFoundError, match=r"no BimanualShift checkpoint at .*nope \(that folder does not"):
        read_json_file(tmp_path / "nope" / "config.json", "BimanualShift checkpoint")
    with pytest.raises(FileNotFoundError, match=r"config.json is missing there"):
        read_json_file(tmp_path / "config.json", "BimanualShift checkpoint")
