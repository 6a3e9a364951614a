"""The hooks every task fills, and registration (``register_task``); looking tasks up is ``sim.task_registry``'s
(it imports every built-in task, which import this module).

A task is a small class: it adds its objects to the scene (``scene_xml``), places and colours them for a
seeded episode (``initialize_episode``), names its goal and instruction, judges success, and scripts an
expert as a list of keyframes. Tasks know nothing about learning; the environment (``sim.env``) runs them.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, TypeVar

import mujoco
import numpy as np

from bimanualshift.core.arms import ARM_NAMES_BIMANUAL, ARM_NAMES_UNIMANUAL
from bimanualshift.core.colours import RGB, TRAIN_COLOURS, UNSEEN_COLOURS
from bimanualshift.sim.perturbations import Perturbations
from bimanualshift.sim.robots import RobotSpec, get_robot

# The gripper pointing straight down as in the Panda's initial pose ((x, y, z, w) quaternion).
# In this pose the fingers open along the world y axis and the hand is thin along x.
DOWN_QUAT = np.array([np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0])


def down_quat(yaw: float) -> np.ndarray:
    """The gripper pointing down, turned by ``yaw`` about the vertical ((x, y, z, w) quaternion).

    A parallel gripper looks the same every half turn, so the yaw is wrapped into [-pi/2, pi/2): the
    smallest wrist rotation from the initial pose, which keeps joint 7 away from its limits.
    """
    from scipy.spatial.transform import Rotation

    yaw = (yaw + np.pi / 2) % np.pi - np.pi / 2
    q = (Rotation.from_euler("z", yaw) * Rotation.from_quat(DOWN_QUAT)).as_quat()
    return q if q[3] >= 0 else -q


def finger_side(geom: str) -> str:
    """Which finger a gripper geom belongs to, "1" or "2" ("" for neither): robosuite names them
    ``gripper0_right_finger1_...`` on a Panda and ``gripper0_right_left_outer_finger_...`` on a Robotiq."""
    rest = geom.split("_", 2)[2] if geom.count("_") >= 2 else geom
    if "finger1" in rest or rest.startswith("left_"):
        return "1"
    if "finger2" in rest or rest.startswith("right_"):
        return "2"
    return ""


@dataclass(frozen=True)
class ArmAction:
    """One arm's keyframe action in the world frame (the layout stored in demos and given to the env)."""

    position: np.ndarray  # (3,)
    quat: np.ndarray  # (4,) x, y, z, w
    gripper_open: float  # 1 open, 0 closed
    ignore_collisions: float = 1.0

    def to_vector(self) -> np.ndarray:
        return np.concatenate(
            [self.position, self.quat, [self.gripper_open, self.ignore_collisions]]
        ).astype(np.float32)

    @staticmethod
    def from_vector(vec: np.ndarray) -> ArmAction:
        vec = np.asarray(vec, dtype=np.float64)
        return ArmAction(vec[:3], vec[3:7], float(vec[7]), float(vec[8]))


ACTION_DIM = 9  # per arm: xyz, quaternion xyzw, gripper open, ignore collisions
Keyframe = dict[str, ArmAction]


class SimHandle:
    """What a task may touch: the MuJoCo model and data plus name lookups."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, table_height: float) -> None:
        self.model = model
        self.data = data
        self.table_height = table_height

    def body_id(self, name: str) -> int:
        idx = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name)
        if idx < 0:
            raise KeyError(f"no body named {name!r} in the scene")
        return idx

    def geom_id(self, name: str) -> int:
        idx = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, name)
        if idx < 0:
            raise KeyError(f"no geom named {name!r} in the scene")
        return idx

    def joint_qpos(self, name: str) -> np.ndarray:
        j = self.model.joint(name)
        adr = j.qposadr[0]
        width = {0: 7, 1: 4, 2: 1, 3: 1}[int(j.type[0])]
        return self.data.qpos[adr : adr + width]

    def joint_qvel(self, name: str) -> np.ndarray:
        j = self.model.joint(name)
        adr = j.dofadr[0]
        width = {0: 6, 1: 3, 2: 1, 3: 1}[int(j.type[0])]
        return self.data.qvel[adr : adr + width]

    def set_free_pose(self, joint: str, position: np.ndarray, quat_xyzw: np.ndarray | None = None) -> None:
        q = np.array([1.0, 0, 0, 0]) if quat_xyzw is None else np.roll(np.asarray(quat_xyzw), 1)
        self.joint_qpos(joint)[:] = np.concatenate([position, q])
        self.joint_qvel(joint)[:] = 0.0

    def set_rgb(self, geom: str, rgb: tuple[float, float, float]) -> None:
        self.model.geom_rgba[self.geom_id(geom), :3] = rgb

    def set_rgb_prefix(self, prefix: str, rgb: tuple[float, float, float]) -> None:
        """Colour every geom whose name starts with ``prefix`` (all parts of one object)."""
        for g in range(self.model.ngeom):
            if self.model.geom(g).name.startswith(prefix):
                self.model.geom_rgba[g, :3] = rgb

    def body_pos(self, name: str) -> np.ndarray:
        return self.data.xpos[self.body_id(name)].copy()

    def pinched(self, body: str) -> bool:
        """Whether both fingers of some gripper touch the named body (it is held, not merely touched)."""
        target = self.body_id(body)
        fingers: set[tuple[str, str]] = set()
        for contact in self.data.contact[: self.data.ncon]:
            for mine, other in ((contact.geom1, contact.geom2), (contact.geom2, contact.geom1)):
                name = self.model.geom(other).name
                if self.model.geom_bodyid[mine] == target and "finger" in name:
                    side = finger_side(name)
                    if side:
                        fingers.add(("_".join(name.split("_")[:2]), side))
        return any((g, "1") in fingers and (g, "2") in fingers for g, _ in fingers)

    def touching_robot(self, body: str) -> bool:
        """Whether any robot or gripper geom touches the named body (e.g. it is still held)."""
        target = self.body_id(body)
        for contact in self.data.contact[: self.data.ncon]:
            pair = (self.model.geom_bodyid[contact.geom1], self.model.geom_bodyid[contact.geom2])
            if target in pair:
                other = pair[1] if pair[0] == target else pair[0]
                if self.model.body(other).name.startswith(("gripper", "robot")):
                    return True
        return False


class Task(ABC):
    """Base class of every task; subclasses are registered with ``@register_task``."""

    name: ClassVar[str]
    bimanual: ClassVar[bool]
    # A single-arm skill added for the bimanual tasks' second arm after the original nine: suite averages report
    # the two groups apart, so easy added skills cannot lift the original suite's figure.
    added_skill: ClassVar[bool] = False
    max_keyframes: ClassVar[int] = 25
    # MuJoCo engine plugins the scene needs (e.g. "mujoco.elasticity.cable" for a rope).
    plugins: ClassVar[tuple[str, ...]] = ()
    # The robot spec (``sim.robots``) the task and its expert are built for, and the others it also runs on
    # (``--robot``); a spec not listed is refused, since its expert was never checked there.
    robot: ClassVar[str] = "panda"
    other_robots: ClassVar[tuple[str, ...]] = ()
    # Root bodies whose mirror image (a left-right exchange) is the body turned half round, not reflected:
    # those symmetric across their own y-z plane but not their x-z plane (``perturb_scene.mirror_bodies``).
    mirrored_by_half_turn: ClassVar[tuple[str, ...]] = ()
    # Where the paper tabulates the task: its tier ("Coordination", "Collaboration", "Precision") and keyframe count
    # (Table II); empty for the tasks it has no such row for.
    tier: ClassVar[str] = ""
    paper_keyframes: ClassVar[int] = 0
    # Control steps (50 ms each) the arms hold a keyframe's pose once they reach it, for tasks whose objects keep
    # moving after the hands stop (poured balls still falling); 0 moves on at once, as RLBench does.
    hold_steps: ClassVar[int] = 0
    # Bodies named with this prefix are particles (poured balls): each settles where the physics puts it, so layout
    # checks compare where they are together (their mean), not one by one.
    particle_prefix: ClassVar[str] = ""

    def __init__(self, perturbations: Perturbations | None = None) -> None:
        self.perturbations = perturbations or Perturbations()
        # JSON-able description of the current episode (colours, targets, ...): part of the env state.
        self.episode: dict[str, Any] = {}

    @property
    def palette(self) -> dict[str, RGB]:
        """The colours objects are drawn from: the training colours unless a study asks for unseen ones."""
        return UNSEEN_COLOURS if self.perturbations.unseen_colours else TRAIN_COLOURS

    def pick_colours(self, rng: np.random.Generator, n: int) -> list[str]:
        return [str(c) for c in rng.choice(list(self.palette), size=n, replace=False)]

    @classmethod
    def robot_spec(cls, robot: str | None = None) -> RobotSpec:
        """``robot`` (default: the task's own) if the task runs on it, else a ValueError naming the ones it runs on."""
        name = robot or cls.robot
        allowed = (cls.robot, *cls.other_robots)
        if name not in allowed:
            raise ValueError(f"task {cls.name!r} runs on the robot {' or '.join(map(repr, allowed))}, not {name!r} "
                             "(its scripted expert was built and checked there)")
        return get_robot(name)

    @property
    def arm_names(self) -> tuple[str, ...]:
        return ARM_NAMES_BIMANUAL if self.bimanual else ARM_NAMES_UNIMANUAL

    @abstractmethod
    def scene_xml(self) -> str:
        """MJCF bodies (as text) added under the world body; root body names become instance names.
        A top-level ``<contact>`` element (pairs, excludes) is merged into the model's contact section, and a
        top-level ``<asset>`` element (materials, textures, meshes) into its assets."""

    @abstractmethod
    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        """Place and colour the objects for a new episode and fill ``self.episode``."""

    @abstractmethod
    def instruction(self) -> str: ...

    def goal_nouns(self) -> list[str]:
        """Object categories the instruction is about (what a segmenter is prompted with): by default the
        direct objects found by ``perception.goal_nouns``' rules; a task overrides this to add context."""
        from bimanualshift.core.goal_nouns import extract_goal_nouns

        return extract_goal_nouns(self.instruction())

    @abstractmethod
    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        """The scripted expert's keyframes for the current episode (world frame)."""

    @abstractmethod
    def evaluate_success(self, sim: SimHandle) -> bool: ...

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        """Per arm, the objects it acts on this episode: root body names, or ``rope:head`` / ``rope:tail`` for
        a rope's ends. The arm-frame coverage check (``sim.coverage``) reads it; empty when a task declares none."""
        return {}

    # A multi-stage task names its stages in order and judges each in ``evaluate_stages`` (stage-wise success,
    # as the paper's generalisation and long-horizon studies report it). The last stage is the task's success.
    stage_names: ClassVar[tuple[str, ...]] = ()

    def evaluate_stages(self, sim: SimHandle) -> list[bool]:
        """Whether each stage's goal holds now (one bool per ``stage_names`` entry)."""
        return []

    def update_stages(self, sim: SimHandle, success: bool) -> int:
        """Latch the stages reached so far (in ``self.episode``, so they are part of the env state) and return
        how many leading stages are done: a stage counts once it and every stage before it has been reached."""
        if not self.stage_names:
            return int(success)
        now = self.evaluate_stages(sim)
        if len(now) != len(self.stage_names):
            raise ValueError(f"{self.name}.evaluate_stages returned {len(now)} values for "
                             f"{len(self.stage_names)} stages {self.stage_names}")
        done = int(self.episode.get("stages_done", 0))
        while done < len(now) and now[done]:
            done += 1
        if success:
            done = len(self.stage_names)
        self.episode["stages_done"] = done
        return done

    def after_compile(self, model: mujoco.MjModel) -> None:  # noqa: B027 - optional hook
        """Adjust the compiled model once (e.g. make generated geoms visible to the cameras)."""

    def on_control_step(self, sim: SimHandle) -> None:  # noqa: B027 - optional hook
        """Called after every control step; tasks latch events (a button pressed once stays pressed)."""

    def instance_name(self, root_body: str) -> str:
        """Instance name of one of this task's root bodies (generated bodies may need a shorter name)."""
        return root_body

    def instance_class(self, instance: str) -> str:
        """Semantic class of one of this task's root bodies (e.g. ``button_1`` -> ``button``)."""
        return instance.rsplit("_", 1)[0] if instance[-1].isdigit() else instance


TASKS: dict[str, type[Task]] = {}
T = TypeVar("T", bound=type[Task])


REALWORLD_PACKAGE = "bimanualshift.sim.tasks.realworld"
ROBOT_SEPARATOR = "@"  # "push_button@ur5e": the task on another robot spec it allows (``Task.other_robots``)


def register_task(name: str) -> Callable[[T], T]:
    """Register a task under ``name``, and under ``name@robot`` for each robot in its ``other_robots``: a task on
    another robot is a task of its own name, so its demos, episodes and results never mix with the original's."""
    def wrap(cls: T) -> T:
        for robot in (None, *cls.other_robots):
            key = name if robot is None else f"{name}{ROBOT_SEPARATOR}{robot}"
            if key in TASKS:
                raise ValueError(f"task {key!r} registered twice ({TASKS[key].__module__} and {cls.__module__})")
            if robot is None:
                cls.name = name
                TASKS[key] = cls
            else:
                get_robot(robot)  # an unknown spec fails at registration
                # added_skill splits the Panda benchmark's suite (its original nine); another robot's suite is whole
                fields = {"name": key, "robot": robot, "other_robots": (), "added_skill": False,
                          "__module__": cls.__module__}
                TASKS[key] = type(f"{cls.__name__}_{robot}", (cls,), fields)
        return cls

    return wrap
