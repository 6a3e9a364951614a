"""The robosuite scene: one or two arms of a robot spec (``sim.robots``) side by side facing a table, plus a task's
objects.

robosuite supplies the robots, grippers and table arena; the task supplies its objects as MJCF. robosuite builds
the model only: its operational-space law runs in ``sim.arm_control``, compiled, at every physics substep, and the
cameras draw low-polygon copies of its visual meshes (``sim.camera_meshes``).
"""

from __future__ import annotations

import logging
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

# robosuite announces optional extras (private macros, robosuite_models, mink IK) at import and warns
# about controller parts an arm does not have on every env: none of it concerns this package.
warnings.filterwarnings("ignore", module="glfw")
logging.disable(logging.WARNING)
try:
    import robosuite  # noqa: F401
finally:
    logging.disable(logging.NOTSET)
logging.getLogger("robosuite_logs").setLevel(logging.ERROR)

from robosuite.controllers import load_composite_controller_config  # noqa: E402
from robosuite.environments.manipulation.manipulation_env import ManipulationEnv  # noqa: E402
from robosuite.models.arenas import TableArena  # noqa: E402
from robosuite.models.robots.robot_model import RobotModel  # noqa: E402
from robosuite.models.tasks import ManipulationTask  # noqa: E402

from bimanualshift.geometry.frames import ArmFrame  # noqa: E402
from bimanualshift.sim.camera_meshes import lighten_visual_meshes  # noqa: E402
from bimanualshift.sim.cameras import camera_xml  # noqa: E402
from bimanualshift.sim.layout import TABLE_SIZE, TABLE_TOP_Z  # noqa: E402
from bimanualshift.sim.props.clutter import clutter_xml  # noqa: E402
from bimanualshift.sim.robots import PANDA, RobotSpec  # noqa: E402
from bimanualshift.sim.task import Task  # noqa: E402


def controller_config(robot: RobotSpec = PANDA) -> dict:
    """The controller robosuite builds its robots with. It never runs: ``sim.arm_control`` evaluates the same
    OSC_POSE law (absolute world-frame targets, the spec's gain) without robosuite's per-substep Python."""
    cfg = load_composite_controller_config(controller="BASIC", robot=robot.arm)
    for part in cfg["body_parts"].values():
        if part.get("type") == "OSC_POSE":
            part["input_type"] = "absolute"
            part["input_ref_frame"] = "world"
            part["kp"] = robot.osc_kp
    return cfg


@contextmanager
def _robot_models_left_uncompiled() -> Iterator[None]:
    """While robosuite loads its robots, each one's MJCF is not compiled on its own into the MjModel robosuite keeps
    for whole-body IK, which nothing here uses: the scene's model is compiled once, whole, as before. That compile
    was half of building a scene: 0.25 s per Panda, 0.9 s per UR5e with its Robotiq 140."""
    compile_alone = RobotModel.set_mujoco_model
    RobotModel.set_mujoco_model = lambda self, mujoco_model=None: None  # type: ignore[method-assign]
    try:
        yield
    finally:
        RobotModel.set_mujoco_model = compile_alone  # type: ignore[method-assign]


class RobosuiteScene(ManipulationEnv):
    """A robosuite environment whose objects, success and resets are defined by a ``Task``, on ``robot``'s arms."""

    def __init__(self, task: Task, robot: RobotSpec = PANDA, **kwargs) -> None:
        self.task = task
        self.robot = robot
        self.arm_names = task.arm_names
        n = len(self.arm_names)
        super().__init__(
            robots=[robot.arm] * n,
            gripper_types=[robot.gripper] * n,
            controller_configs=[controller_config(robot)] * n,
            has_renderer=False,
            has_offscreen_renderer=False,
            use_camera_obs=False,
            hard_reset=False,
            control_freq=20,
            horizon=10**9,
            ignore_done=True,
            initialization_noise=None,
            **kwargs,
        )

    def _load_model(self) -> None:
        with _robot_models_left_uncompiled():
            super()._load_model()
        ys = self.robot.base_ys(self.task.bimanual)
        for robot, arm in zip(self.robots, self.arm_names):
            xpos = np.array(robot.robot_model.base_xpos_offset["table"](TABLE_SIZE[0]))
            robot.robot_model.set_base_xpos(xpos + np.array([0.0, ys[arm], 0.0]))
        arena = TableArena(table_full_size=TABLE_SIZE, table_offset=(0.0, 0.0, TABLE_TOP_Z))
        arena.set_origin([0, 0, 0])
        self.model = ManipulationTask(mujoco_arena=arena, mujoco_robots=[r.robot_model for r in self.robots])
        for name, (pos, target) in self.robot.static_cameras.items():
            self.model.worldbody.append(camera_xml(name, pos, target, self.robot.camera_fovy))
        if self.task.plugins:
            extension = ET.SubElement(self.model.root, "extension")
            for plugin in self.task.plugins:
                ET.SubElement(extension, "plugin", plugin=plugin)
        clutter = clutter_xml(self.task.perturbations.clutter)  # none unless the perturbation asks for it
        objects = ET.fromstring(f"<root>{self.task.scene_xml()}{clutter}</root>")
        for element in objects:
            if element.tag == "contact":  # pairs and excludes go to the model's own <contact> section
                self.model.contact.extend(list(element))
            elif element.tag == "asset":  # materials, textures and meshes the task's bodies use
                self.model.asset.extend(list(element))
            elif element.tag == "equality":  # constraints between the task's bodies (a cloth's corner tabs)
                self.model.equality.extend(list(element))
            else:
                self.model.worldbody.append(element)
        lighten_visual_meshes(self.model.root)

    def reward(self, action: np.ndarray | None = None) -> float:
        return 0.0

    def arm_frames(self) -> dict[str, ArmFrame]:
        frames = {}
        for robot, arm in zip(self.robots, self.arm_names):
            pos = self.sim.data.get_body_xpos(robot.robot_model.root_body)
            frames[arm] = ArmFrame(position=tuple(float(v) for v in pos), yaw=0.0)
        return frames
