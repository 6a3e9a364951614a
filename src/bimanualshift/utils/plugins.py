"""A user's own tasks and priors, from outside the package: entry points and ``--plugin MODULE``.

A plugin is any module that registers something when imported (``@register_task``, ``@register_prior``). Two
ways in, both imported on the first registry lookup in every process:

* an installed package declares entry points in the groups ``bimanualshift.tasks`` / ``bimanualshift.priors``
  (``[project.entry-points."bimanualshift.tasks"] my_tasks = "my_package.tasks"``);
* ``--plugin MODULE`` on any command (a module name on the path, or a ``.py`` file), which lands in the
  environment variable ``BIMANUALSHIFT_PLUGINS``; spawned worker processes and Ray workers inherit it, so a
  user's task works in ``collect``, ``train``, ``bench`` and their workers alike.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import sys
from importlib.metadata import entry_points
from pathlib import Path

PLUGINS_ENV = "BIMANUALSHIFT_PLUGINS"
ENTRY_POINT_GROUPS = ("bimanualshift.tasks", "bimanualshift.priors")
_loaded: set[str] = set()


class PluginError(ImportError):
    """A plugin named by ``--plugin`` or an entry point could not be imported."""


def add_plugins(modules: list[str]) -> None:
    """Record ``modules`` for this process and every worker it starts, then import them."""
    named = [m for m in os.environ.get(PLUGINS_ENV, "").split(os.pathsep) if m]
    for module in modules:
        if module.endswith(".py"):
            module = str(Path(module).resolve())  # workers may start elsewhere
        if module not in named:
            named.append(module)
    os.environ[PLUGINS_ENV] = os.pathsep.join(named)
    load_plugins()


def load_plugins() -> list[str]:
    """Import every plugin not imported yet (entry points, then ``BIMANUALSHIFT_PLUGINS``); their names."""
    new = []
    for group in ENTRY_POINT_GROUPS:
        for point in entry_points(group=group):
            key = f"entry point {point.name} = {point.value}"
            if key in _loaded:
                continue
            _loaded.add(key)
            try:
                point.load()
            except Exception as err:  # a broken plugin names itself, not a deep traceback
                raise PluginError(f"{key} (group {group}) failed to import: {err}") from err
            new.append(point.value)
    for module in [m for m in os.environ.get(PLUGINS_ENV, "").split(os.pathsep) if m]:
        if module in _loaded:
            continue
        _loaded.add(module)
        _import(module)
        new.append(module)
    return new


def _import(module: str) -> None:
    if module.endswith(".py"):
        path = Path(module)
        if not path.is_file():
            raise PluginError(f"plugin file {module} does not exist; pass --plugin path/to/file.py or a module name")
        name = f"bimanualshift_plugin_{path.stem}"
        spec = importlib.util.spec_from_file_location(name, path)
        assert spec is not None and spec.loader is not None
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod
        try:
            spec.loader.exec_module(mod)
        except Exception as err:
            del sys.modules[name]
            raise PluginError(f"plugin {module} failed to import: {type(err).__name__}: {err}") from err
        return
    try:
        importlib.import_module(module)
    except ModuleNotFoundError as err:
        if err.name and module.startswith(err.name):
            raise PluginError(f"no plugin module {module!r} on the Python path; install it, run from its folder, "
                              "or pass the file: --plugin path/to/file.py") from err
        raise PluginError(f"plugin {module} failed to import: {err}") from err
    except Exception as err:
        raise PluginError(f"plugin {module} failed to import: {type(err).__name__}: {err}") from err
