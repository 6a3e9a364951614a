"""Which registered tasks the suite's per-task tests run on, and which of those are slow to simulate."""

from __future__ import annotations

from bimanualshift.sim.task_registry import task_names

# A Panda task's twin variant ("task@ur5e") changes the robot alone: two variants stand for all of them here, and
# every variant's expert has its 100-seed record in results/experts_ur5e.json.
SAMPLED_VARIANTS = ("pick_cube@ur5e", "push_two_buttons@ur5e")

# Tasks whose physics (a cloth, a cable or rope, 40 balls) makes one expert episode 2-15 s. Their experts' 100-seed
# records are results/experts_quilt.json, experts_cable.json, experts_pouring.json and experts.json.
SLOW_PHYSICS = frozenset({"quilt_folding", "fold_corner", "cable_routing", "route_cable", "pouring_water", "pour_cup",
                          "straighten_rope", "pull_rope_end"})


def suite_tasks(bimanual: bool | None = None) -> list[str]:
    """Every task built for a robot, plus the sampled variants (of one kind where ``bimanual`` says)."""
    return [t for t in task_names(bimanual=bimanual) if "@" not in t or t in SAMPLED_VARIANTS]
