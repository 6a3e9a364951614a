from __future__ import annotations

from dataclasses import dataclass

import pytest

from bimanualshift.cli import main
from bimanualshift.cli.parsing import parse


@dataclass
class Example:
    plain: int = 1
    beside: float = 0.5  # weight of the thing (50 % by default)
    # A block above the field,
    # over two lines.
    above: str = "x"
    text: str = "a # not a comment"
    switch: bool = True  # a boolean
    model: dict | None = None  # a JSON object


def _help(cls: type, capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit) as exc:
        parse(cls, ["--help"], "prog", "about")
    assert exc.value.code == 0
    return " ".join(capsys.readouterr().out.replace("│", " ").split())


def test_comments_beside_and_above_fields_become_their_help(capsys: pytest.CaptureFixture[str]) -> None:
    text = _help(Example, capsys)
    assert "weight of the thing (50 % by default) (default: 0.5)" in text
    assert "A block above the field, over two lines." in text
    assert "a # not a comment" in text and "(default: 1)" in text


def test_the_command_line_shows_the_config_comments(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["train", "--help"])
    assert "weight of the rotation term in L_BC" in " ".join(capsys.readouterr().out.replace("│", " ").split())


def test_earlier_flag_spellings_still_parse() -> None:
    """Booleans as true/false in any case (and a bare flag), dicts as one JSON object, as earlier command lines
    wrote them."""
    assert parse(Example, ["--switch", "false"], "p", "d").switch is False
    assert parse(Example, ["--switch", "TRUE"], "p", "d").switch is True
    assert parse(Example, ["--switch"], "p", "d").switch is True
    assert parse(Example, ["--model", '{"dim": 64}'], "p", "d").model == {"dim": 64}
    with pytest.raises(SystemExit) as exc:
        parse(Example, ["--switch", "maybe"], "p", "d")
    assert exc.value.code == 2


def test_study_flags_override_only_what_is_given() -> None:
    from bimanualshift.cli.evaluate import StudyArgs

    args = parse(StudyArgs, ["table1", "--episodes", "100", "--tasks", "lift_ball", "--recorded-only"], "p", "a")
    assert (args.name, args.recorded_only) == ("table1", True)
    given = {k: v for k, v in vars(args.overrides).items() if v is not None}
    assert given == {"episodes": 100, "tasks": ["lift_ball"]}
