from __future__ import annotations

import argparse
from dataclasses import dataclass

from bimanualshift.cli import _add_config_overrides, build_parser
from bimanualshift.training.residual import TrainConfig
from bimanualshift.utils.field_help import field_help


@dataclass
class Example:
    plain: int = 1
    beside: float = 0.5  # weight of the thing (50 % by default)
    # A block above the field,
    # over two lines.
    above: str = "x"  # and a note beside it
    text: str = "a # not a comment"

    def method(self) -> int:  # a method's comment is not a field's
        return 1


def test_comments_beside_and_above_fields_become_their_help() -> None:
    assert field_help(Example) == {"beside": "weight of the thing (50 % by default)",
                                   "above": "A block above the field, over two lines. and a note beside it"}


def test_the_command_line_shows_the_config_comments() -> None:
    assert "weight of the rotation term" in field_help(TrainConfig)["beta"]
    help_text = build_parser()._subparsers._group_actions[0].choices["train"].format_help()  # noqa: SLF001
    assert "weight of the rotation term in L_BC" in help_text
    parser = argparse.ArgumentParser()
    _add_config_overrides(parser, Example)
    assert "weight of the thing (50 % by default) (default: 0.5)" in " ".join(parser.format_help().split())
