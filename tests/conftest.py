"""Shared fixtures: simulation-backed ones are session-scoped, built once and reused."""

from __future__ import annotations

from pathlib import Path

import pytest

from bimanualshift.data.collect import collect
from bimanualshift.data.episode import list_episodes


@pytest.fixture(scope="session")
def demo_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two bimanual and two single-arm expert episodes per task used by the tests, collected once."""
    root = tmp_path_factory.mktemp("demos")
    collect(["push_two_buttons"], [0, 1], root / "bimanual")
    collect(["push_button", "pick_cube"], [0, 1], root / "unimanual")
    return root


@pytest.fixture(scope="session")
def bimanual_episode_path(demo_root: Path) -> Path:
    paths = list_episodes(demo_root / "bimanual", "push_two_buttons")
    assert paths, "expert failed to produce a push_two_buttons demo"
    return paths[0]
