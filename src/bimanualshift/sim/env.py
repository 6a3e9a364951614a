"""Gymnasium environment: one step = one keyframe per arm, executed by a motion executor.

Observation (a dict): ``cameras`` {name: {rgb, depth, instance, class}}, ``intrinsics`` / ``extrinsics``
{name: matrix}, ``proprio`` (n_arms, 8) = end-effector position, quaternion (x, y, z, w), gripper open, in
the world frame, ``instruction`` (str), ``keyframe_index`` (int). Action: (n_arms, 9) per arm
``[x, y, z, qx, qy, qz, qw, gripper_open, ignore_collisions]`` in the world frame. Cameras are rendered
once per keyframe, never at every control step.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

from bimanualshift.core.goal_nouns import split_prompt
from bimanualshift.geometry.frames import ArmFrame, canonical_quat, rotation_angle, slerp
from bimanualshift.sim.arm_control import ArmIndexes, OscArms
from bimanualshift.sim.cameras import CameraRig, default_camera_names, wrist_camera_names
from bimanualshift.sim.layout import TABLE_TOP_Z, WORKSPACE_HIGH, WORKSPACE_LOW
from bimanualshift.sim.perturb_scene import apply_to_model, mirror_bodies
from bimanualshift.sim.perturbations import Perturbations
from bimanualshift.sim.props.clutter import place_clutter
from bimanualshift.sim.scene import RobosuiteScene
from bimanualshift.sim.segmentation import NAMED_COLOURS, SceneInstances
from bimanualshift.sim.task import ACTION_DIM, ROBOT_SEPARATOR, ArmAction, Keyframe, SimHandle, Task
from bimanualshift.sim.task_registry import make_task, task_class

PROPRIO_DIM = 8


# Model fields a task or perturbation may set per episode; data fields that make up the simulator's state.
MODEL_EPISODE_FIELDS = ("body_pos", "body_quat", "geom_rgba", "geom_size", "geom_pos", "geom_quat", "geom_matid",
                        "geom_friction", "body_mass", "jnt_range", "dof_damping", "flex_rgba")
DATA_STATE_FIELDS = ("qpos", "qvel", "act", "ctrl", "qacc_warmstart")
MOCAP_STATE_FIELDS = ("mocap_pos", "mocap_quat")  # where a task's mocap bodies (a cable's clamp) hold things
CLUTTER_STREAM = 0xC1  # the clutter pieces' random stream, apart from the task's own draws


@dataclass(frozen=True)
class ArmCommand:
    """One control step's command for every arm, in this env's arm order (world frame)."""

    positions: np.ndarray  # (n_arms, 3)
    quats_wxyz: np.ndarray  # (n_arms, 4)
    gripper_open: np.ndarray  # (n_arms,) 1 open, 0 closed


class InvalidActionError(ValueError):
    """An action with the wrong shape, NaNs or a target outside the reachable workspace."""


class ManipulationEnv(gym.Env):
    metadata = {"render_modes": ["rgb_array"]}

    def __init__(self, task: str | Task, image_size: int | None = None, camera_names: tuple[str, ...] | None = None,
                 max_steps_per_keyframe: int = 90, perturbations: Perturbations | None = None,
                 robot: str | None = None) -> None:
        if robot and isinstance(task, str) and robot != task_class(task).robot:
            task = f"{task}{ROBOT_SEPARATOR}{robot}"  # the task's variant on that robot, if it allows it
        self.task = make_task(task, perturbations) if isinstance(task, str) else task
        if perturbations is not None and not isinstance(task, str):
            self.task.perturbations = perturbations
        self.perturbations = self.task.perturbations
        self.robot = self.task.robot_spec(robot)  # the task's own robot unless another it allows is asked for
        image_size = image_size or self.robot.image_size
        self.arm_names = self.task.arm_names
        self.scene = RobosuiteScene(self.task, self.robot)
        self.scene.reset()
        self.model: mujoco.MjModel = self.scene.sim.model._model
        self.data: mujoco.MjData = self.scene.sim.data._data
        self.sim = SimHandle(self.model, self.data, TABLE_TOP_Z)
        self.task.after_compile(self.model)
        apply_to_model(self.model, self.perturbations, tuple(self.robot.static_cameras))
        self.arms = OscArms(self.model, self.data, [ArmIndexes.of_robot(self.model, r, self.robot)
                                                    for r in self.scene.robots], kp=self.robot.osc_kp)
        self._grippers = [(r._ref_gripper_joint_pos_indexes["right"], np.asarray(r.gripper["right"].init_qpos))
                          for r in self.scene.robots]
        # What an episode may change in the model (placements, colours): restored at every reset, so an episode
        # never inherits the one before it.
        self._model_fields = {key: getattr(self.model, key).copy() for key in MODEL_EPISODE_FIELDS}
        self.camera_names = camera_names or default_camera_names(self.arm_names, self.robot)
        self.cameras = CameraRig(self.model, self.camera_names, wrist_camera_names(self.arm_names),
                                 image_size, image_size, fovy=self.robot.camera_fovy)
        self.instances = SceneInstances.from_model(self.model, self.task, self.arm_names)
        self.arm_frames: dict[str, ArmFrame] = self.scene.arm_frames()
        fixed = {"table", "world", *(r.robot_model.root_body for r in self.scene.robots)}
        self._task_roots = [  # the task's own objects: what a left-right swap mirrors
            b for b in range(1, self.model.nbody)
            if self.model.body_parentid[b] == 0 and self.model.body(b).name not in fixed
            and not self.model.body(b).name.startswith("mount")
        ]
        self.max_steps_per_keyframe = max_steps_per_keyframe
        self._dense: list[dict[str, np.ndarray]] | None = None
        self._video: tuple[tuple[str, ...], int, list[np.ndarray]] | None = None  # cameras, every n steps, frames
        self._steps = 0
        self.render_timings: dict[str, list[float]] | None = None  # ms per camera/pass, when a profiler asks
        self.keyframe_index = 0
        self.gripper_open = {arm: 1.0 for arm in self.arm_names}
        n = len(self.arm_names)
        self.action_space = gym.spaces.Box(-np.inf, np.inf, shape=(n, ACTION_DIM), dtype=np.float32)
        self.observation_space = gym.spaces.Dict({
            "proprio": gym.spaces.Box(-np.inf, np.inf, shape=(n, PROPRIO_DIM), dtype=np.float32),
            "instruction": gym.spaces.Text(max_length=256),
            "keyframe_index": gym.spaces.Discrete(self.task.max_keyframes + 1),
        })

    # ---- episode control -------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, Any], dict[str, Any]]:
        super().reset(seed=seed)
        self._reset_physics()
        self.task.initialize_episode(self.sim, np.random.default_rng(seed))
        mujoco.mj_forward(self.model, self.data)
        if self.perturbations.swap_sides:
            half_turned = tuple(self.sim.body_id(name) for name in self.task.mirrored_by_half_turn)
            mirror_bodies(self.model, self.data, self._task_roots, half_turned)
        if self.perturbations.clutter:
            self._place_clutter(seed)
        self.keyframe_index = 0
        self.gripper_open = {arm: 1.0 for arm in self.arm_names}
        options = options or {}
        if options.get("settle", True):  # False: the poses initialize_episode set, before physics moves them
            self._settle(steps=5)
        render = bool(options.get("render", True))
        return self.observe(render=render), {"instruction": self.task.instruction()}

    def _place_clutter(self, seed: int | None) -> None:
        """The clutter pieces among this episode's objects, in its goal objects' colours. Their draws come from a
        stream of their own, so the task's layout is the same scene's with or without them (paired episodes)."""
        goal_classes = {split_prompt(p)[1] for p in self.task.goal_nouns()}
        painted = self.instance_colours()
        names = [c for n, cls in zip(self.instances.names, self.instances.instance_class)
                 if self.instances.classes[cls] in goal_classes for c in painted.get(n, [])]
        colours = [NAMED_COLOURS[c] for c in dict.fromkeys(names)] or list(self.task.palette.values())
        rng = np.random.default_rng(None if seed is None else [seed, self.perturbations.seed, CLUTTER_STREAM])
        place_clutter(self.model, self.data, self._task_roots, colours, rng)
        mujoco.mj_forward(self.model, self.data)

    def _reset_physics(self) -> None:
        """Everything back to the compiled scene: model fields, MuJoCo's state (warm start included), the arms at
        their home joints with the controller holding that pose, grippers open. Nothing of an earlier episode
        survives."""
        for key, value in self._model_fields.items():
            getattr(self.model, key)[:] = value
        mujoco.mj_resetData(self.model, self.data)
        for arm, (gripper_qpos, gripper_home) in zip(self.arms.arms, self._grippers):
            self.data.qpos[arm.qpos] = arm.home
            self.data.qpos[gripper_qpos] = gripper_home
        mujoco.mj_forward(self.model, self.data)
        self.arms.reset()
        self.task.episode = {}

    def step(self, action: np.ndarray, render: bool = True
             ) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        targets = self._parse_action(action)
        self.execute(targets)
        self.keyframe_index += 1
        success = self.task.evaluate_success(self.sim)
        stages = self.task.update_stages(self.sim, success)
        truncated = self.keyframe_index >= self.task.max_keyframes
        return (self.observe(render=render), float(success), success, truncated,
                {"success": success, "stages_done": stages})

    def expert_keyframes(self) -> list[Keyframe]:
        return self.task.expert_keyframes(self.sim)

    def action_from_keyframe(self, keyframe: Keyframe) -> np.ndarray:
        """The (n_arms, 9) action array ``step`` takes, rows in this env's arm order."""
        return np.stack([keyframe[arm].to_vector() for arm in self.arm_names])

    def success(self) -> bool:
        return self.task.evaluate_success(self.sim)

    # ---- state -----------------------------------------------------------------------------------------
    def get_state(self) -> dict[str, Any]:
        return {
            **{key: getattr(self.data, key).copy() for key in DATA_STATE_FIELDS},
            "gripper_action": self.arms.gripper_action.copy(),
            "body_pos": self.model.body_pos.copy(),
            "body_quat": self.model.body_quat.copy(),
            "geom_rgba": self.model.geom_rgba.copy(),
            "flex_rgba": self.model.flex_rgba.copy(),  # a cloth's colour
            **{key: getattr(self.data, key).copy() for key in MOCAP_STATE_FIELDS},  # a clamp's pose
            "episode": copy.deepcopy(self.task.episode),
            "keyframe_index": self.keyframe_index,
            "gripper_open": dict(self.gripper_open),
        }

    def set_state(self, state: dict[str, Any]) -> None:
        # states saved before cloths and clamps existed have no flex_rgba or mocap poses; their scenes had neither
        optional = tuple(key for key in ("flex_rgba", *MOCAP_STATE_FIELDS) if key in state)
        for key in (*DATA_STATE_FIELDS, "body_pos", "body_quat", "geom_rgba", *optional):
            target = getattr(self.data if key in DATA_STATE_FIELDS + MOCAP_STATE_FIELDS else self.model, key)
            if np.shape(state[key]) != target.shape:
                raise ValueError(f"state[{key!r}] has shape {np.shape(state[key])}, this scene needs {target.shape}")
            target[:] = state[key]
        self.task.episode = copy.deepcopy(state["episode"])
        self.keyframe_index = int(state["keyframe_index"])
        self.gripper_open = dict(state["gripper_open"])
        self.arms.gripper_action[:] = state["gripper_action"]
        mujoco.mj_forward(self.model, self.data)

    # ---- observation -----------------------------------------------------------------------------------
    def instance_colours(self) -> dict[str, list[str]]:
        """Instance name -> the named colours painted on it this episode (what a colour prompt matches)."""
        return self.instances.painted_colours(self.model)

    def proprio(self) -> np.ndarray:
        rows = []
        for i, arm in enumerate(self.arm_names):
            pos, quat = self.eef_pose(i)
            rows.append(np.r_[pos, quat, self.gripper_open[arm]])
        return np.asarray(rows, dtype=np.float32)

    def observe(self, render: bool = True) -> dict[str, Any]:
        # mj_step leaves positions computed before its integration: bring them up to date with qpos so an
        # observation depends on the state alone (and a restored state renders identically).
        mujoco.mj_forward(self.model, self.data)
        obs: dict[str, Any] = {
            "proprio": self.proprio(),
            "instruction": self.task.instruction(),
            "keyframe_index": self.keyframe_index,
        }
        if render:
            frames = self.cameras.render(self.data, timings=self.render_timings)
            obs["cameras"] = {
                name: {
                    "rgb": f.rgb,
                    "depth": f.depth,
                    "instance": self.instances.instance_of_geom(f.geom),
                    "class": self.instances.class_of_geom(f.geom),
                }
                for name, f in frames.items()
            }
            obs["intrinsics"] = {name: f.intrinsics for name, f in frames.items()}
            obs["extrinsics"] = {name: f.extrinsics for name, f in frames.items()}
        return obs

    def render(self) -> np.ndarray:
        return self._video_frame((self.camera_names[0],))

    # ---- execution -------------------------------------------------------------------------------------
    def eef_pose(self, robot_index: int) -> tuple[np.ndarray, np.ndarray]:
        robot = self.scene.robots[robot_index]
        site = robot.eef_site_id["right"]
        pos = self.data.site_xpos[site].copy()
        wxyz = np.empty(4)
        mujoco.mju_mat2Quat(wxyz, self.data.site_xmat[site])  # MuJoCo's own conversion: the executor's hot path
        return pos, canonical_quat(np.roll(wxyz, -1))

    def _parse_action(self, action: np.ndarray) -> Keyframe:
        a = np.asarray(action, dtype=np.float64)
        n = len(self.arm_names)
        if a.shape != (n, ACTION_DIM):
            raise InvalidActionError(
                f"action must have shape ({n}, {ACTION_DIM}) = one row per arm {self.arm_names} of "
                f"[x, y, z, qx, qy, qz, qw, gripper_open, ignore_collisions]; got shape {a.shape}"
            )
        if not np.all(np.isfinite(a)):
            raise InvalidActionError(f"action contains NaN or infinite values: {a.tolist()}")
        targets = {}
        for arm, row in zip(self.arm_names, a):
            if np.any(row[:3] < WORKSPACE_LOW) or np.any(row[:3] > WORKSPACE_HIGH):
                raise InvalidActionError(
                    f"{arm} arm target {row[:3].round(3).tolist()} is outside the workspace "
                    f"{WORKSPACE_LOW.tolist()} .. {WORKSPACE_HIGH.tolist()} (world frame, metres)"
                )
            if np.linalg.norm(row[3:7]) < 1e-6:
                raise InvalidActionError(f"{arm} arm quaternion {row[3:7].tolist()} has zero norm")
            targets[arm] = ArmAction(row[:3], canonical_quat(row[3:7]), float(row[7] > 0.5), float(row[8] > 0.5))
        return targets

    def _robot_command(self, positions: dict[str, np.ndarray], quats_xyzw: dict[str, np.ndarray]) -> ArmCommand:
        quats = np.stack([np.roll(quats_xyzw[arm], 1) for arm in self.arm_names])  # (w, x, y, z)
        return ArmCommand(np.stack([positions[arm] for arm in self.arm_names]), quats,
                          np.array([self.gripper_open[arm] for arm in self.arm_names]))

    def _control_step(self, command: ArmCommand) -> None:
        self.arms.command(command.positions, command.quats_wxyz, command.gripper_open)
        self.arms.step()
        self.task.on_control_step(self.sim)
        self._steps += 1
        if self._dense is not None:
            self._dense.append(self._dense_sample())
        if self._video is not None and self._steps % self._video[1] == 0:
            self._video[2].append(self._video_frame(self._video[0]))

    # ---- videos ----------------------------------------------------------------------------------------
    def start_video(self, cameras: tuple[str, ...] = ("front",), every: int = 2) -> None:
        """Record a frame (the given cameras side by side) every ``every`` control steps until collected."""
        unknown = [c for c in cameras if c not in self.camera_names]
        if unknown:
            raise ValueError(f"unknown camera(s) {unknown}; this environment has {list(self.camera_names)}")
        self._video = (tuple(cameras), max(1, int(every)), [self._video_frame(tuple(cameras))])

    def video_frames(self) -> list[np.ndarray]:
        """The frames recorded since ``start_video``; recording stops."""
        if self._video is None:
            raise RuntimeError("call start_video() before video_frames()")
        frames, self._video = self._video[2], None
        return frames

    def _video_frame(self, cameras: tuple[str, ...]) -> np.ndarray:
        # Drawn from a copy brought up to date there: the controller reads what the last physics step computed,
        # so a recorded episode must leave the simulator's own data untouched to stay the same episode.
        data = copy.copy(self.data)
        mujoco.mj_forward(self.model, data)
        return np.concatenate([self.cameras.render_rgb(data, c) for c in cameras], axis=1)

    # ---- dense trajectories ----------------------------------------------------------------------------
    def start_dense_recording(self) -> None:
        """Record every control step from now on (joints, end-effector poses, grippers) until collected."""
        self._dense = [self._dense_sample()]

    def dense_trajectory(self) -> dict[str, np.ndarray]:
        """The recorded control steps: joint_positions / joint_velocities (T, arms, joints), eef_pose (T, arms, 7:
        xyz + quaternion xyzw) and gripper_open (T, arms). Recording stops."""
        if self._dense is None:
            raise RuntimeError("call start_dense_recording() before dense_trajectory()")
        samples, self._dense = self._dense, None
        return {key: np.stack([s[key] for s in samples]).astype(np.float32) for key in samples[0]}

    def _dense_sample(self) -> dict[str, np.ndarray]:
        robots = self.scene.robots
        poses = [np.r_[self.eef_pose(i)] for i in range(len(robots))]
        return {
            "joint_positions": np.stack([self.data.qpos[r._ref_joint_pos_indexes] for r in robots]),
            "joint_velocities": np.stack([self.data.qvel[r._ref_joint_vel_indexes] for r in robots]),
            "eef_pose": np.stack(poses),
            "gripper_open": np.array([self.gripper_open[a] for a in self.arm_names]),
        }

    def servo(self, positions: dict[str, np.ndarray], quats_xyzw: dict[str, np.ndarray],
              gripper_open: dict[str, float]) -> None:
        """One control step towards per-arm end-effector targets (a teleoperator's stream, not keyframes)."""
        for arm in self.arm_names:
            self.gripper_open[arm] = float(gripper_open[arm] > 0.5)
        self._control_step(self._robot_command(positions, {a: canonical_quat(q) for a, q in quats_xyzw.items()}))

    def _settle(self, steps: int) -> None:
        positions, rotations = {}, {}
        for i, arm in enumerate(self.arm_names):
            pos, quat = self.eef_pose(i)
            positions[arm], rotations[arm] = pos, quat
        for _ in range(steps):
            self._control_step(self._robot_command(positions, rotations))

    def execute(self, targets: Keyframe, max_step_m: float = 0.012, max_step_rad: float = 0.1) -> bool:
        """Move every arm to its keyframe pose, then switch grippers. Returns whether all poses were reached.

        Plays the role of RLBench's motion planner: the commanded pose advances towards the target by at
        most ``max_step_m`` / ``max_step_rad`` per control step and the OSC controller tracks it.
        """
        start = {arm: self.eef_pose(i) for i, arm in enumerate(self.arm_names)}
        cmd_pos = {arm: start[arm][0].copy() for arm in self.arm_names}
        fractions, rot_steps = {}, {}
        for arm in self.arm_names:
            angle = rotation_angle(start[arm][1], targets[arm].quat)
            rot_steps[arm] = 1.0 if angle < 1e-6 else min(1.0, max_step_rad / angle)
            fractions[arm] = 0.0
        reached = False
        still_steps = 0  # control steps in a row in which no hand moved (blocked by contact: a squeeze, a push)
        previous = np.stack([self.eef_pose(i)[0] for i in range(len(self.arm_names))])
        for _ in range(self.max_steps_per_keyframe):
            rotations = {}
            for arm in self.arm_names:
                delta = targets[arm].position - cmd_pos[arm]
                dist = np.linalg.norm(delta)
                cmd_pos[arm] = cmd_pos[arm] + (delta if dist <= max_step_m else delta * max_step_m / dist)
                fractions[arm] = min(1.0, fractions[arm] + rot_steps[arm])
                rotations[arm] = slerp(start[arm][1], targets[arm].quat, fractions[arm])
            self._control_step(self._robot_command(cmd_pos, rotations))
            reached = all(self._pose_error(i, targets[arm]) for i, arm in enumerate(self.arm_names))
            if reached:
                break
            current = np.stack([self.eef_pose(i)[0] for i in range(len(self.arm_names))])
            commanded_all = all(np.allclose(cmd_pos[a], targets[a].position) and fractions[a] >= 1.0
                                for a in self.arm_names)
            still_steps = still_steps + 1 if commanded_all and np.abs(current - previous).max() < 5e-4 else 0
            previous = current
            if still_steps >= 6:
                break
        changed = [arm for arm in self.arm_names if targets[arm].gripper_open != self.gripper_open[arm]]
        for arm in changed:
            self.gripper_open[arm] = targets[arm].gripper_open
        final_rot = {arm: canonical_quat(targets[arm].quat) for arm in self.arm_names}
        # the grippers switch over 12 steps; a task whose objects keep moving holds the pose longer
        for _ in range((12 if changed else 0) + self.task.hold_steps):
            self._control_step(self._robot_command(cmd_pos, final_rot))
        return reached

    def _pose_error(self, robot_index: int, target: ArmAction, tol_m: float = 0.006, tol_rad: float = 0.06) -> bool:
        pos, quat = self.eef_pose(robot_index)
        return bool(np.linalg.norm(pos - target.position) < tol_m and rotation_angle(target.quat, quat) < tol_rad)

    def close(self) -> None:
        self.cameras.close()
        self.scene.close()
