"""Shared fixtures: simulation-backed ones are session-scoped, built once and reused."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import torch

from bimanualshift.data.collect import collect
from bimanualshift.data.episode import list_episodes

# Under pytest-xdist every worker gets a core: torch's own threads would then fight over the same two cores, and
# OpenMP's spin-waits make a contended step ~25x slower (measured on the RVT debug model: 2.1 s vs 0.08 s).
if os.environ.get("PYTEST_XDIST_WORKER"):
    torch.set_num_threads(1)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Files holding slow tests run first (each file's own order kept): on CI's two workers a long file scheduled
    last would run alone at the end while the other worker idles; the many quick files fill that tail instead."""
    slow_files = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.path not in slow_files)


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
