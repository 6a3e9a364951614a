from __future__ import annotations

import gc
import weakref

import numpy as np

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
