from __future__ import annotations

import gc
import os
import subprocess
import sys
import weakref
from pathlib import Path

import numpy as np

import bimanualshift
from bimanualshift.sim.env import ManipulationEnv


def test_an_environment_and_its_cameras_are_freed_once_dropped() -> None:
    """A study creates hundreds of environments in one process: nothing may keep a dropped one (and its model and
    render buffers) alive, closed or not."""
    closed = ManipulationEnv("lift_ball", image_size=32)
    first = closed.reset(seed=0)[0]
    rigs = [weakref.ref(closed.cameras)]
    closed.close()
    closed.close()  # a second close is harmless
    unclosed = ManipulationEnv("lift_ball", image_size=32)
    again = unclosed.reset(seed=0)[0]
    rigs.append(weakref.ref(unclosed.cameras))
    # a second context in the same process renders the same frame after the first one was freed
    for camera, frame in first["cameras"].items():
        np.testing.assert_array_equal(again["cameras"][camera]["rgb"], frame["rgb"])
    del closed, unclosed
    gc.collect()
    assert all(rig() is None for rig in rigs)


EXIT_SCRIPT = """
import weakref
weakref.finalize(type("Early", (), {})(), print)  # a library made a finaliser before any rig existed
from bimanualshift.sim.env import ManipulationEnv
kept = ManipulationEnv("lift_ball", image_size=32)
kept.reset(seed=0)
ManipulationEnv("lift_ball", image_size=32).close()
print("done")
"""


def test_a_process_exits_cleanly_with_environments_still_open() -> None:
    """The GL contexts of rigs alive at exit are freed before mujoco terminates the EGL display."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(bimanualshift.__file__).parents[1]),
                                                         os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", EXIT_SCRIPT], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0 and out.stdout.strip().endswith("done"), out.stderr[-2000:]
    assert "Error" not in out.stderr, out.stderr[-2000:]
