"""Instance and class labels for every MuJoCo geom, so rendered geom ids become segmentation maps.

An instance is a body tree hanging from the world: each robot (with its mount and gripper), the table, and
each of the task's objects. Instance 0 is the background (floor, walls, sky).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from bimanualshift.core.colours import TRAIN_COLOURS, UNSEEN_COLOURS
from bimanualshift.sim.props.clutter import CLUTTER_CLASS, CLUTTER_PREFIX
from bimanualshift.sim.task import Task

ARM_CLASS = "robotic arm"
NAMED_COLOURS = {**TRAIN_COLOURS, **UNSEEN_COLOURS}
BACKGROUND = "background"


@dataclass
class SceneInstances:
    names: list[str]  # instance id -> name, e.g. "background", "arm_left", "table", "button_0"
    classes: list[str]  # class id -> name, e.g. "background", "robotic arm", "table", "button"
    instance_class: np.ndarray  # instance id -> class id
    geom_instance: np.ndarray  # geom id -> instance id

    @staticmethod
    def from_model(model: mujoco.MjModel, task: Task, arm_names: tuple[str, ...]) -> SceneInstances:
        robot_roots = {f"robot{i}_base": arm for i, arm in enumerate(arm_names)}
        names, classes = [BACKGROUND], [BACKGROUND]
        instance_class = [0]
        root_instance: dict[int, int] = {}
        flex_vertices = set(model.flex_vertbodyid.tolist()) if model.nflex else set()
        for body in range(1, model.nbody):
            if model.body_parentid[body] != 0 or body in flex_vertices:  # a cloth's vertices draw nothing
                continue
            root = model.body(body).name
            if root in robot_roots:
                name, cls = f"arm_{robot_roots[root]}", ARM_CLASS
            elif root.startswith("mount"):  # robosuite mounts are separate roots for some robots
                name, cls = root, ARM_CLASS
            elif root == "table":
                name, cls = "table", "table"
            elif root.startswith(CLUTTER_PREFIX):  # the clutter perturbation's pieces: never a goal
                name, cls = root, CLUTTER_CLASS
            else:
                # the class of the instance's name, not of the root body's: a rope's root is its first
                # segment ("rope_B_first"), its instance "rope" and so its class "rope", the goal noun
                name = task.instance_name(root)
                cls = task.instance_class(name)
            if cls not in classes:
                classes.append(cls)
            root_instance[body] = len(names)
            names.append(name)
            instance_class.append(classes.index(cls))
        geom_instance = np.array(
            [root_instance.get(int(model.body_rootid[model.geom_bodyid[g]]), 0) for g in range(model.ngeom)],
            dtype=np.int16,
        )
        return SceneInstances(names, classes, np.asarray(instance_class, np.int16), geom_instance)

    def painted_colours(self, model: mujoco.MjModel) -> dict[str, list[str]]:
        """Instance name -> the named colours (``core.colours``) some geom of it is painted exactly, in palette
        order: the ground-truth attribute a colour prompt ("navy button") is matched against. Read after the
        episode's reset: tasks paint their objects there."""
        names = list(NAMED_COLOURS)
        palette = np.asarray(list(NAMED_COLOURS.values()), dtype=np.float64)
        # (geoms, colours): which palette colour each geom's RGB is (set_rgb stores it as float32)
        match = np.abs(model.geom_rgba[:, None, :3].astype(np.float64) - palette[None]).max(-1) < 1e-3
        out: dict[str, list[str]] = {}
        for instance in range(1, len(self.names)):
            painted = match[self.geom_instance == instance].any(0)
            if painted.any():
                out[self.names[instance]] = [names[i] for i in np.flatnonzero(painted)]
        return out

    def instance_of_geom(self, geom_ids: np.ndarray) -> np.ndarray:
        lut = np.r_[self.geom_instance, 0]  # index -1 (no geom) maps to background
        return lut[geom_ids]

    def class_of_geom(self, geom_ids: np.ndarray) -> np.ndarray:
        return self.instance_class[self.instance_of_geom(geom_ids)]

