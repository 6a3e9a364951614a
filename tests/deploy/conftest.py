"""A small valid observation and a stateful stand-in policy: what the protocol tests need without a simulator."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.deploy.server import PolicyServer, ServerConfig

TOKEN = "a-test-token-of-some-length"


class CountingPolicy:
    """Moves each arm 1 cm up per keyframe since its last reset: a reply shows whose state the server used."""

    name = "counting"

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.count = 0

    def act(self, obs: KeyframeObservation) -> np.ndarray:
        self.count += 1
        rows = np.zeros((len(obs.scene.arm_names), 9), np.float32)
        rows[:, :7] = obs.proprio[:, :7]
        rows[:, 2] += 0.01 * self.count
        rows[:, 7] = 1.0
        return rows

    def action_chunk(self) -> np.ndarray:
        """The next two keyframes: the reply carries them as a chunk."""
        return np.zeros((2, 2, 9), np.float32)

    def keyframe_log(self) -> dict[str, Any]:
        return {"count": self.count, "retrieval_similarity": 0.5}


def valid_message(episode: str = "ep-0", keyframe: int = 0, side: int = 8) -> dict[str, Any]:
    rng = np.random.default_rng(keyframe)
    # two cameras 1.5 m above the table looking straight down, 90 degrees across: together they see the table top
    k = np.array([[side / 2, 0, side / 2], [0, side / 2, side / 2], [0, 0, 1]])
    down = np.array([[1.0, 0, 0, 0], [0, -1, 0, 0], [0, 0, -1, 2.3], [0, 0, 0, 1]])
    cameras = {name: {"rgb": rng.integers(0, 255, (side, side, 3), dtype=np.uint8),
                      "depth": np.full((side, side), 1.0, np.float32), "intrinsics": k, "extrinsics": down,
                      "instance": np.zeros((side, side), np.int16), "class": np.zeros((side, side), np.int16)}
               for name in ("front", "overhead")}
    arms = {arm: {"pose": np.array([0.1, y, 1.0, 0, 0, 0, 1], np.float32), "gripper_open": 1.0,
                  "base": np.array([-0.56, y, 0.91])} for arm, y in (("left", 0.3), ("right", -0.3))}
    return {"schema_version": 1, "episode_id": episode, "keyframe": keyframe, "instruction": "push the buttons",
            "cameras": cameras, "arms": arms, "instance_names": ["background"], "class_names": ["background"]}


@pytest.fixture
def server() -> Iterator[PolicyServer]:
    srv = PolicyServer(CountingPolicy(), {"checkpoint": "counting", "schema_version": 1},
                       ServerConfig(port=0, token=TOKEN, max_message_bytes=256 * 1024, idle_timeout_s=30))
    srv.start_background()
    yield srv
    srv.stop()
