"""Environments built once per worker process (``utils.process_cache``)."""

from __future__ import annotations

from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.perturbations import preset
from bimanualshift.utils.process_cache import cached


def cached_env(task: str, perturbation: str = "none", image_size: int | None = None) -> ManipulationEnv:
    """This process's ``ManipulationEnv`` of ``task`` under a perturbation preset at ``image_size`` (None: its
    robot's)."""
    return cached(("env", task, perturbation, image_size),
                  lambda: ManipulationEnv(task, image_size=image_size, perturbations=preset(perturbation)))
