"""The robot as configuration: which arm and gripper, where the bases stand, how the arms are driven and which
cameras watch them. The scene, the arm controller, the executor and the camera rig read a ``RobotSpec``; a task
names the spec it was built for (``Task.robot``) and ``--robot`` selects another where the task allows it.

Two specs ship: ``panda``, the benchmark's two Franka Pandas with six cameras (RLBench2's rig), and ``ur5e``, the
paper's real platform as a twin: two UR5e arms with robosuite's 140 mm Robotiq gripper (the stand-in for the
PGI-140) side by side behind the table, and one front RGB-D camera with a RealSense-L515-like view at 256x256.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from bimanualshift.sim.layout import BIMANUAL_ARM_Y, TABLE_TOP_Z, UNIMANUAL_ARM_Y

Placement = tuple[tuple[float, float, float], tuple[float, float, float]]  # position, look-at point (world)

# RLBench2's static cameras around the table (robots at x = -0.56, table top at z = 0.8)
RLBENCH2_CAMERAS: dict[str, Placement] = {
    "front": ((0.95, 0.0, 1.4), (0.0, 0.0, 0.85)),
    "overhead": ((0.15, 0.0, 2.05), (0.0, 0.0, 0.8)),
    "over_shoulder_left": ((-0.3, 0.95, 1.5), (0.05, 0.0, 0.8)),
    "over_shoulder_right": ((-0.3, -0.95, 1.5), (0.05, 0.0, 0.8)),
}


@dataclass(frozen=True)
class RobotSpec:
    name: str
    arm: str  # robosuite's robot class
    gripper: str  # robosuite's gripper class
    # How the gripper's two finger commands move, per control step, when it opens: robosuite's ``format_action``
    # for an "open" (-1) action. A Panda's fingers go (+, -) to open, a Robotiq's linkages (-, +).
    gripper_open_direction: tuple[float, float]
    gripper_speed: float = 0.2  # fraction of the normalised range per control step (robosuite's ``speed``)
    base_y: dict[str, float] = field(default_factory=lambda: dict(BIMANUAL_ARM_Y))  # two arms
    single_arm_y: dict[str, float] = field(default_factory=lambda: dict(UNIMANUAL_ARM_Y))  # one arm
    home_qpos: tuple[float, ...] = ()  # the arms' home joints; () keeps robosuite's ``init_qpos``
    static_cameras: dict[str, Placement] = field(default_factory=lambda: dict(RLBENCH2_CAMERAS))
    wrist_cameras: bool = True
    image_size: int = 128
    camera_fovy: float = 60.0  # vertical field of view of the static cameras (degrees)
    osc_kp: float = 300.0  # the operational-space stiffness the experts are tuned with

    def base_ys(self, bimanual: bool) -> dict[str, float]:
        return self.base_y if bimanual else self.single_arm_y


ROBOTS: dict[str, RobotSpec] = {}


def register_robot(spec: RobotSpec) -> RobotSpec:
    """Add a robot spec (a plugin may register its own); a name already taken by another spec is refused."""
    if spec.name in ROBOTS and ROBOTS[spec.name] != spec:
        raise ValueError(f"a robot named {spec.name!r} is already registered")
    ROBOTS[spec.name] = spec
    return spec


def get_robot(name: str) -> RobotSpec:
    if name not in ROBOTS:
        raise ValueError(f"unknown robot {name!r}; registered: {', '.join(sorted(ROBOTS))}")
    return ROBOTS[name]


PANDA = register_robot(RobotSpec(name="panda", arm="Panda", gripper="PandaGripper",
                                 gripper_open_direction=(1.0, -1.0)))

# The paper's platform: a RealSense L515 in front of the table looking back at the two arms (its depth field of
# view is 70 x 55 degrees; the 256x256 crop keeps the vertical 55), no wrist cameras.
UR5E = register_robot(RobotSpec(
    name="ur5e", arm="UR5e", gripper="Robotiq140Gripper", gripper_open_direction=(-1.0, 1.0),
    static_cameras={"front": ((0.85, 0.0, TABLE_TOP_Z + 0.75), (-0.12, 0.0, TABLE_TOP_Z))},
    wrist_cameras=False, image_size=256, camera_fovy=55.0))
