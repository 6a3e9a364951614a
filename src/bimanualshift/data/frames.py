"""One keyframe's multi-camera observation, whether it comes from a live env or a stored episode."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bimanualshift.data.episode import Episode


@dataclass
class SceneInfo:
    """What stays fixed within an episode: names of cameras, arms, segmentation labels, goal nouns."""

    camera_names: list[str]
    arm_names: list[str]
    instance_names: list[str]
    class_names: list[str]
    goal_nouns: list[str]
    arm_bases: dict[str, list[float]]
    # instance name -> the colour names painted on it (the simulator's ground truth, like its class labels);
    # empty when unknown (real cameras, older recordings): a colour prompt then matches every instance of its noun
    instance_colours: dict[str, list[str]] = field(default_factory=dict)


@dataclass
class KeyframeObservation:
    rgb: np.ndarray  # (C, H, W, 3) uint8
    depth: np.ndarray  # (C, H, W) float32
    instance: np.ndarray  # (C, H, W) int16
    class_ids: np.ndarray  # (C, H, W) int16
    intrinsics: np.ndarray  # (C, 3, 3)
    extrinsics: np.ndarray  # (C, 4, 4)
    proprio: np.ndarray  # (A, 8) world frame
    instruction: str
    keyframe_index: int
    scene: SceneInfo

    @staticmethod
    def from_episode(episode: Episode, k: int) -> KeyframeObservation:
        a = episode.arrays
        return KeyframeObservation(
            a["rgb"][k], a["depth"][k], a["instance"][k], a["class"][k], a["intrinsics"][k], a["extrinsics"][k],
            a["proprio"][k], episode.instruction, k, scene_of_episode(episode),
        )

    @staticmethod
    def from_env(obs: dict[str, Any], scene: SceneInfo) -> KeyframeObservation:
        cams = scene.camera_names
        return KeyframeObservation(
            np.stack([obs["cameras"][c]["rgb"] for c in cams]),
            np.stack([obs["cameras"][c]["depth"] for c in cams]),
            np.stack([obs["cameras"][c]["instance"] for c in cams]),
            np.stack([obs["cameras"][c]["class"] for c in cams]),
            np.stack([obs["intrinsics"][c] for c in cams]),
            np.stack([obs["extrinsics"][c] for c in cams]),
            np.asarray(obs["proprio"], np.float32), obs["instruction"], int(obs["keyframe_index"]), scene,
        )


def scene_of_episode(episode: Episode) -> SceneInfo:
    return SceneInfo(episode.camera_names, episode.arm_names, episode.instance_names, episode.class_names,
                     episode.goal_nouns, episode.arm_bases, episode.instance_colours)


def scene_of_env(env: Any) -> SceneInfo:
    """The current episode's scene description (call after ``reset``: goal nouns follow the instruction)."""
    if not env.task.episode:
        raise RuntimeError("reset the environment before describing its scene: the goal nouns come from the "
                           "episode's instruction")
    return SceneInfo(list(env.camera_names), list(env.arm_names), env.instances.names, env.instances.classes,
                     env.task.goal_nouns(), {arm: list(f.position) for arm, f in env.arm_frames.items()},
                     env.instance_colours())
