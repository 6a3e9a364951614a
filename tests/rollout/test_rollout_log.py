"""The rollout's per-keyframe log: where the arms ended beside where they were sent."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.evaluation.explain import keyframe_profile, widest_gap
from bimanualshift.rollout.loop import rollout
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.layout import WORKSPACE_LOW


class RaiseThenDive:
    """Keyframe 0: both arms 3 cm up (reachable). Keyframe 1: the left arm sent to the workspace's floor, 2 cm
    below the table top (its fingers stop on the table); the right arm stays."""

    name = "raise_then_dive"

    def reset(self) -> None:
        self.k = 0

    def act(self, obs: KeyframeObservation) -> np.ndarray:
        rows = np.zeros((len(obs.scene.arm_names), 9), np.float32)
        rows[:, :7] = obs.proprio[:, :7]
        rows[:, 7] = 1.0
        rows[:, 2] += 0.03 if self.k == 0 else 0.0
        if self.k == 1:
            rows[0, 2] = WORKSPACE_LOW[2] + 0.001
        self.k += 1
        return rows


@pytest.mark.slow
def test_each_keyframe_logs_the_poses_the_arms_reached() -> None:
    env = ManipulationEnv("push_two_buttons")
    try:
        record = rollout(env, RaiseThenDive(), seed=0, max_keyframes=2)
        final = env.proprio()
    finally:
        env.close()
    first, second = record.steps
    reached = np.asarray(second["reached"])
    assert reached.shape == (2, 8)
    np.testing.assert_allclose(reached, final, atol=1e-4)  # the last row is where the episode left the arms
    sent = np.asarray(first["executed"])
    assert np.linalg.norm(np.asarray(first["reached"])[:, :3] - sent[:, :3], axis=-1).max() < 0.01
    # the dive is logged as commanded, and the arm ends above it, on the table
    commanded_z, reached_z = second["executed"][0][2], second["reached"][0][2]
    assert reached_z - commanded_z > 0.02


def _steps(short_cm: float) -> list[dict[str, Any]]:
    pose = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0]
    reached = [pose[:2] + [pose[2] - short_cm / 100] + pose[3:], pose]
    return [{"keyframe": 0, "executed": [pose + [1.0]] * 2, "expert": [pose + [1.0]] * 2, "reached": reached}]


def test_tracking_profile_shows_where_failures_stop_short() -> None:
    failures = keyframe_profile([_steps(5.0), _steps(4.0)], measured="reached", reference="executed")
    successes = keyframe_profile([_steps(0.2)], measured="reached", reference="executed")
    assert failures["left"] == [[4.5, 0.0]] and failures["right"] == [[0.0, 0.0]]
    gap = widest_gap(failures, successes)
    assert gap is not None and (gap["keyframe"], gap["arm"], gap["what"]) == (0, "left", "position")
    # a log from before the reached poses were kept gives no tracking profile, and no error
    old = [{k: v for k, v in row.items() if k != "reached"} for row in _steps(5.0)]
    assert keyframe_profile([old], measured="reached", reference="executed") == {}
