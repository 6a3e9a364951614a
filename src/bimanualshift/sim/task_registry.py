"""Looking tasks up: every built-in task and the user's plugins registered on first use, by name, kind, robot
and group. It lives apart from ``sim.task`` because the built-in tasks import that module to register."""

from __future__ import annotations

from bimanualshift.sim.perturbations import Perturbations
from bimanualshift.sim.task import REALWORLD_PACKAGE, ROBOT_SEPARATOR, TASKS, Task


def _register_all() -> None:
    from bimanualshift.sim import tasks  # noqa: F401 - importing registers every built-in task
    from bimanualshift.utils.plugins import load_plugins

    load_plugins()  # and the user's (entry points, --plugin)


def make_task(name: str, perturbations: Perturbations | None = None) -> Task:
    _register_all()
    if name not in TASKS:
        raise KeyError(f"unknown task {name!r}; registered tasks: {', '.join(sorted(TASKS))}")
    return TASKS[name](perturbations)


def task_class(name: str) -> type[Task]:
    _register_all()
    if name not in TASKS:
        raise KeyError(f"unknown task {name!r}; registered tasks: {', '.join(sorted(TASKS))}")
    return TASKS[name]


def task_names(bimanual: bool | None = None, robot: str | None = None) -> list[str]:
    """Registered task names, of one kind (``bimanual``) and on one robot spec (``robot``) where given."""
    _register_all()
    return sorted(n for n, c in TASKS.items() if (bimanual is None or c.bimanual == bimanual)
                  and (robot is None or c.robot == robot))


# names resolve_task_names expands to several tasks: every task, and per robot spec its two-arm and single-arm
# tasks ("bimanual" and "unimanual" are the Panda's, the benchmark's; "bimanual_ur5e", "unimanual_ur5e", ...)
TASK_GROUPS = ("all", "bimanual", "unimanual")


def task_groups() -> dict[str, list[str]]:
    groups = {"all": task_names(), "bimanual": task_names(True, "panda"), "unimanual": task_names(False, "panda")}
    for robot in sorted({c.robot for c in TASKS.values()} - {"panda"}):
        groups[f"bimanual_{robot}"] = task_names(True, robot)
        groups[f"unimanual_{robot}"] = task_names(False, robot)
    # the paper's real-world tasks, built for its platform's twin (sim/tasks/realworld/)
    groups["realworld"] = sorted(n for n, c in TASKS.items() if c.__module__.startswith(REALWORLD_PACKAGE)
                                 and ROBOT_SEPARATOR not in n)
    return groups


def resolve_task_names(requested: list[str]) -> list[str]:
    """Registered task names from names and the groups of ``task_groups`` ('all', 'bimanual', 'unimanual', ...)."""
    known = task_names()
    groups = task_groups()
    tasks = list(dict.fromkeys(t for name in requested for t in groups.get(name, [name])))
    bad = [t for t in tasks if t not in known]
    if bad:
        raise ValueError(f"unknown task(s) {bad}; choose from {known}, or one of the groups {', '.join(groups)}")
    return tasks
