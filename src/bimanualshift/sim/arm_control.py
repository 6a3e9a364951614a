"""Arm control at physics speed: robosuite's operational-space controller, compiled and batched over the arms.

robosuite evaluates its OSC in Python at every 2 ms physics substep (25 per control step), through layers of
per-robot bookkeeping, after a full ``mj_forward``: 6-8x the physics it drives. Here the same law runs at every
substep too, but as one numba-compiled function over both arms (``osc_torques``), on the kinematic stages it
reads (positions, Jacobians, mass matrix, bias forces: ``mj_kinematics`` .. ``mj_rne``, a few microseconds;
no collision detection), and the executor hands it a goal once per control step.

The law is robosuite's OSC_POSE with position and orientation uncoupled (its default): for each arm,
tau = J_p^T Lambda_p (kp e_p - kd v) + J_r^T Lambda_r (kp e_r - kd w) + the dynamically consistent nullspace
pull to the home posture (kp_null = 10, critically damped) + MuJoCo's bias forces (gravity and Coriolis), with
robosuite's orientation error and kp = 300 (the robot spec's ``osc_kp``), kd = 2 sqrt(kp); MuJoCo clips the
torques to the arm's limits (the motors' ctrlrange). Any number of joints: a Panda's 7, a UR5e's 6 (no nullspace
left). The grippers keep robosuite's position servos and its ramp (the spec's ``gripper_speed`` of the range per
control step, in the direction its ``format_action`` moves the fingers). Cheaper variants (the law every 5
substeps, or on state one substep old, or joint servos tracking a once-per-step target) changed the contact
behaviour the experts rely on; docs/simulation.md has their figures.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
from numba import njit

from bimanualshift.sim.robots import PANDA, RobotSpec

SUBSTEPS = 25  # physics steps of 2 ms per 50 ms control step
OSC_KP = 300.0  # the Panda spec's: stiffer than robosuite's default 150, so presses and grasps reach their targets
NULLSPACE_KP = 10.0  # robosuite's pull towards the home posture, in the nullspace
NULLSPACE_KD = 2.0 * np.sqrt(NULLSPACE_KP)


@dataclass
class ArmIndexes:
    """Where one arm lives in the compiled model."""

    qpos: np.ndarray  # (joints,) qpos addresses of the arm joints
    dofs: np.ndarray  # (joints,) dof addresses
    actuators: np.ndarray  # (joints,) torque motor ids
    site: int  # end-effector site id
    gripper_actuators: np.ndarray  # (2,) finger servo ids
    home: np.ndarray  # (joints,) initial joint positions
    gripper_open: np.ndarray = field(default_factory=lambda: np.array([1.0, -1.0]))  # finger commands' way open
    gripper_speed: float = 0.2

    @staticmethod
    def of_robot(model: mujoco.MjModel, robot: object, spec: RobotSpec = PANDA) -> ArmIndexes:
        """Read a robosuite robot's names (robosuite builds the model; it no longer runs the controller)."""
        rm = robot.robot_model  # type: ignore[attr-defined]
        joints = [model.joint(name).id for name in rm.joints]
        gripper = robot.gripper["right"]  # type: ignore[attr-defined]
        return ArmIndexes(
            qpos=np.array([model.jnt_qposadr[j] for j in joints]),
            dofs=np.array([model.jnt_dofadr[j] for j in joints]),
            actuators=np.array([model.actuator(name).id for name in rm.actuators]),
            site=int(robot.eef_site_id["right"]),  # type: ignore[attr-defined]
            gripper_actuators=np.array([model.actuator(name).id for name in gripper.actuators]),
            home=np.asarray(spec.home_qpos or rm.init_qpos, dtype=np.float64),
            gripper_open=np.asarray(spec.gripper_open_direction, dtype=np.float64),
            gripper_speed=spec.gripper_speed,
        )


class OscArms:
    """Drives every arm to its commanded end-effector pose; one ``command`` + ``step`` per control step."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, arms: list[ArmIndexes], kp: float = OSC_KP) -> None:
        self.model, self.data, self.arms = model, data, arms
        self.kp = float(kp)
        n = len(arms)
        self._dofs = np.stack([a.dofs for a in arms])  # (n, 7)
        self._qpos = np.stack([a.qpos for a in arms])
        self._acts = np.stack([a.actuators for a in arms])
        self._home = np.stack([a.home for a in arms])
        self._jacp = np.zeros((n, 3, model.nv))
        self._jacr = np.zeros((n, 3, model.nv))
        self._mat9 = np.zeros(9)
        self._mass = np.zeros((model.nv, model.nv))
        self._bias = np.zeros(model.nv)
        self._sites = np.array([a.site for a in arms])
        self.goal_pos = np.zeros((n, 3))
        self.goal_mat = np.tile(np.eye(3), (n, 1, 1))
        self.gripper_action = np.zeros((n, 2))

    # ---- per episode ------------------------------------------------------------------------------------------
    def reset(self) -> None:
        """Hold the current pose, grippers open (call after the joints are placed and ``mj_forward``)."""
        d = self.data
        for i, arm in enumerate(self.arms):
            self.goal_pos[i] = d.site_xpos[arm.site]
            self.goal_mat[i] = d.site_xmat[arm.site].reshape(3, 3)
            self.gripper_action[i] = arm.gripper_open  # fully open
        self._apply_grippers()
        d.ctrl[self._acts] = 0.0

    # ---- per control step ---------------------------------------------------------------------------------
    def command(self, positions: np.ndarray, quats_wxyz: np.ndarray, gripper_open: np.ndarray) -> None:
        """Set every arm's goal pose and gripper for the next control step (world frame)."""
        self.goal_pos[:] = positions
        for i, quat in enumerate(quats_wxyz):
            mujoco.mju_quat2Mat(self._mat9, quat)
            self.goal_mat[i] = self._mat9.reshape(3, 3)
        for i, arm in enumerate(self.arms):  # robosuite's format_action: a ramp towards open or closed
            way = arm.gripper_open if gripper_open[i] > 0.5 else -arm.gripper_open
            self.gripper_action[i] = np.clip(self.gripper_action[i] + arm.gripper_speed * way, -1.0, 1.0)
        self._apply_grippers()

    def step(self) -> None:
        """One control step: the OSC law, then one physics substep, ``SUBSTEPS`` times."""
        for _ in range(SUBSTEPS):
            self._apply_osc()
            mujoco.mj_step(self.model, self.data)

    def _apply_grippers(self) -> None:
        for i, arm in enumerate(self.arms):
            acts = arm.gripper_actuators
            low, high = self.model.actuator_ctrlrange[acts, 0], self.model.actuator_ctrlrange[acts, 1]
            self.data.ctrl[acts] = 0.5 * (high + low) + 0.5 * (high - low) * self.gripper_action[i]

    def _apply_osc(self) -> None:
        m, d = self.model, self.data
        # The state's positions, Jacobians, mass matrix and bias forces, as robosuite's mj_forward before each
        # substep gives them, without the collision and constraint stages the law does not read.
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_crb(m, d)
        mujoco.mj_comVel(m, d)
        mujoco.mj_rne(m, d, 0, self._bias)
        mujoco.mj_fullM(m, self._mass, d.qM)
        for i, site in enumerate(self._sites):
            mujoco.mj_jacSite(m, d, self._jacp[i], self._jacr[i], site)
        # Writes the torques into ctrl; MuJoCo clips them to the motors' ctrlrange (the Panda's torque limits).
        osc_torques(self._jacp, self._jacr, self._mass, self._bias, self._dofs, self._qpos, self._sites,
                    self._acts, d.site_xpos, d.site_xmat, d.qpos, d.qvel, self.goal_pos, self.goal_mat, self._home,
                    d.ctrl, self.kp)


@njit(cache=True, nogil=True)
def osc_torques(jacp: np.ndarray, jacr: np.ndarray, full_mass: np.ndarray, bias: np.ndarray, dofs: np.ndarray,
                qpos_adr: np.ndarray, sites: np.ndarray, actuators: np.ndarray, site_xpos: np.ndarray,
                site_xmat: np.ndarray, qpos: np.ndarray, qvel: np.ndarray, goal_pos: np.ndarray, goal_mat: np.ndarray,
                home: np.ndarray, ctrl: np.ndarray, kp: float) -> None:
    """robosuite's OSC_POSE torques for every arm, written into ``ctrl`` (compiled: it runs every substep).

    Per arm: position error and robosuite's orientation error (half the sum of the cross products of the current
    and goal rotation matrices' columns), the twist J qdot, the uncoupled operational-space inertias, the
    dynamically consistent nullspace pull to the home posture, and the bias forces."""
    n, k = dofs.shape
    for i in range(n):
        idx = dofs[i]
        mass = np.empty((k, k))
        j = np.empty((6, k))
        v = np.empty(k)
        q = np.empty(k)
        for r in range(k):
            v[r] = qvel[idx[r]]
            q[r] = qpos[qpos_adr[i, r]]
            for c in range(k):
                mass[r, c] = full_mass[idx[r], idx[c]]
            for a in range(3):
                j[a, r] = jacp[i, a, idx[r]]
                j[3 + a, r] = jacr[i, a, idx[r]]
        mass_inv = np.linalg.inv(mass)
        twist = j @ v
        current = site_xmat[sites[i]].reshape(3, 3)
        error = np.zeros(6)
        error[:3] = goal_pos[i] - site_xpos[sites[i]]
        for col in range(3):
            error[3:] += 0.5 * np.cross(current[:, col], goal_mat[i][:, col])
        wrench_goal = kp * error - 2.0 * np.sqrt(kp) * twist  # critically damped
        inv_full = j @ mass_inv @ j.T
        wrench = np.empty(6)
        wrench[:3] = np.linalg.inv(inv_full[:3, :3]) @ wrench_goal[:3]
        wrench[3:] = np.linalg.inv(inv_full[3:, 3:]) @ wrench_goal[3:]
        jbar = mass_inv @ j.T @ np.linalg.inv(inv_full)
        null = np.eye(k) - jbar @ j
        posture = mass @ (NULLSPACE_KP * (home[i] - q) - NULLSPACE_KD * v)
        torque = j.T @ wrench + null.T @ posture
        for r in range(k):
            ctrl[actuators[i, r]] = torque[r] + bias[idx[r]]
