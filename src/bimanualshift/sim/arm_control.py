"""Arm control at physics speed: robosuite's operational-space controller, lean, batched over the arms.

robosuite evaluates its OSC in Python at every 2 ms physics substep (25 per control step), through layers of
per-robot bookkeeping; that costs several times the physics it drives. Here the same law runs batched over
both arms every ``OSC_EVERY`` substeps and MuJoCo integrates the held torque in between (``mj_step`` with
``nstep``, in C).

The law is robosuite's OSC_POSE with position and orientation uncoupled (its default): for each arm,
tau = J_p^T Lambda_p (kp e_p - kd v) + J_r^T Lambda_r (kp e_r - kd w) + nullspace pull to the home posture
(kp_null = 10, critically damped) + MuJoCo's bias forces (gravity and Coriolis), clipped to the Panda's torque
limits by MuJoCo (the motors' ctrlrange). kp = 300, critically damped (kd = 2 sqrt(kp)).

Why not once per control step: a torque held for 50 ms at kp = 300 (natural frequency 17 rad/s) is
unstable, and joint servos tracking a once-per-step target only approximate the OSC's task-space stiffness;
both changed the contact behaviour the scripted experts rely on (a squeeze, a press, a pinch) and their success
fell to 20-80 % on several tasks. Every 5 substeps (10 ms, 100 Hz) the held torque is well inside the OSC's
stability margin (omega * dt = 0.17) and the experts behave as before.

The grippers keep robosuite's position servos and its ramp of 0.2 of the range per control step.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

SUBSTEPS = 25  # physics steps of 2 ms per 50 ms control step
OSC_EVERY = 5  # physics steps between two evaluations of the OSC law (100 Hz)
OSC_KP = 300.0  # robosuite's OSC gain as this project configures it (sim.scene used kp = 300)
OSC_KD = 2.0 * np.sqrt(OSC_KP)  # critically damped
NULLSPACE_KP = 10.0  # robosuite's pull towards the home posture, in the nullspace
NULLSPACE_KD = 2.0 * np.sqrt(NULLSPACE_KP)
GRIPPER_RAMP = 0.2  # robosuite's Panda gripper speed: fraction of the normalised range per control step


@dataclass
class ArmIndexes:
    """Where one arm lives in the compiled model."""

    qpos: np.ndarray  # (7,) qpos addresses of the arm joints
    dofs: np.ndarray  # (7,) dof addresses
    actuators: np.ndarray  # (7,) torque motor ids
    site: int  # end-effector site id
    gripper_actuators: np.ndarray  # (2,) finger servo ids
    home: np.ndarray  # (7,) initial joint positions

    @staticmethod
    def of_robot(model: mujoco.MjModel, robot: object) -> ArmIndexes:
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
            home=np.asarray(rm.init_qpos, dtype=np.float64),
        )


class OscArms:
    """Drives every arm to its commanded end-effector pose; one ``command`` + ``step`` per control step."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, arms: list[ArmIndexes]) -> None:
        self.model, self.data, self.arms = model, data, arms
        n = len(arms)
        self._dofs = np.stack([a.dofs for a in arms])  # (n, 7)
        self._qpos = np.stack([a.qpos for a in arms])
        self._acts = np.stack([a.actuators for a in arms])
        self._home = np.stack([a.home for a in arms])
        self._jacp = np.zeros((3, model.nv))
        self._jacr = np.zeros((3, model.nv))
        self._jac = np.zeros((n, 6, len(arms[0].dofs)))
        self._quat = np.zeros(4)
        self._err_quat = np.zeros(4)
        self._rot_err = np.zeros(3)
        self._mass = np.zeros((model.nv, model.nv))
        self.goal_pos = np.zeros((n, 3))
        self.goal_quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        self.gripper_action = np.zeros((n, 2))

    # ---- per episode ------------------------------------------------------------------------------------------
    def reset(self) -> None:
        """Hold the current pose, grippers open (call after the joints are placed and ``mj_forward``)."""
        d = self.data
        for i, arm in enumerate(self.arms):
            self.goal_pos[i] = d.site_xpos[arm.site]
            mujoco.mju_mat2Quat(self.goal_quat[i], d.site_xmat[arm.site])
            self.gripper_action[i] = (1.0, -1.0)
        self._apply_grippers()
        d.ctrl[self._acts] = 0.0

    # ---- per control step ---------------------------------------------------------------------------------
    def command(self, positions: np.ndarray, quats_wxyz: np.ndarray, gripper_open: np.ndarray) -> None:
        """Set every arm's goal pose and gripper for the next control step (world frame)."""
        self.goal_pos[:] = positions
        self.goal_quat[:] = quats_wxyz
        direction = np.where(np.asarray(gripper_open) > 0.5, -1.0, 1.0)[:, None]  # robosuite: -1 opens
        self.gripper_action[:] = np.clip(self.gripper_action + np.array([-1.0, 1.0]) * GRIPPER_RAMP * direction,
                                         -1.0, 1.0)
        self._apply_grippers()

    def step(self) -> None:
        """One control step: the OSC law every ``OSC_EVERY`` substeps, MuJoCo integrating in between."""
        done = 0
        while done < SUBSTEPS:
            n = min(OSC_EVERY, SUBSTEPS - done)
            self._apply_osc()
            mujoco.mj_step(self.model, self.data, n)
            done += n

    def _apply_grippers(self) -> None:
        for i, arm in enumerate(self.arms):
            acts = arm.gripper_actuators
            low, high = self.model.actuator_ctrlrange[acts, 0], self.model.actuator_ctrlrange[acts, 1]
            self.data.ctrl[acts] = 0.5 * (high + low) + 0.5 * (high - low) * self.gripper_action[i]

    def _apply_osc(self) -> None:
        m, d = self.model, self.data
        # Positions, Jacobians, the mass matrix and the bias forces as the last mj_step computed them, at the
        # start of its last substep (one 2 ms step old; robosuite recomputes them with an mj_forward here, which
        # costs a whole physics stage for a delay far inside the law's margin).
        mujoco.mj_fullM(m, self._mass, d.qM)
        errors = np.zeros((len(self.arms), 6))
        for i, arm in enumerate(self.arms):
            mujoco.mj_jacSite(m, d, self._jacp, self._jacr, arm.site)
            self._jac[i, :3] = self._jacp[:, arm.dofs]
            self._jac[i, 3:] = self._jacr[:, arm.dofs]
            mujoco.mju_mat2Quat(self._quat, d.site_xmat[arm.site])
            mujoco.mju_negQuat(self._err_quat, self._quat)
            mujoco.mju_mulQuat(self._err_quat, self.goal_quat[i], self._err_quat)
            mujoco.mju_quat2Vel(self._rot_err, self._err_quat, 1.0)
            errors[i, :3] = self.goal_pos[i] - d.site_xpos[arm.site]
            errors[i, 3:] = self._rot_err
        q, qvel = d.qpos[self._qpos], d.qvel[self._dofs]  # (n, 7)
        mass = self._mass[self._dofs[:, :, None], self._dofs[:, None, :]]  # (n, 7, 7)
        mass_inv = np.linalg.inv(mass)
        jac, jac_t = self._jac, self._jac.transpose(0, 2, 1)
        velocity = jac @ qvel[:, :, None]  # (n, 6, 1) end-effector twist
        wrench_goal = OSC_KP * errors[:, :, None] - OSC_KD * velocity
        inv_full = jac @ mass_inv @ jac_t  # (n, 6, 6)
        lam_p = np.linalg.inv(inv_full[:, :3, :3])
        lam_r = np.linalg.inv(inv_full[:, 3:, 3:])
        wrench = np.concatenate([lam_p @ wrench_goal[:, :3], lam_r @ wrench_goal[:, 3:]], axis=1)
        torque = (jac_t @ wrench)[:, :, 0]
        # Nullspace pull to the home posture, through the dynamically consistent nullspace (robosuite's form).
        lam = np.linalg.inv(inv_full + 1e-8 * np.eye(6))
        jbar = mass_inv @ jac_t @ lam  # (n, 7, 6)
        null = np.eye(q.shape[1]) - jbar @ jac
        posture = mass @ (NULLSPACE_KP * (self._home - q) - NULLSPACE_KD * qvel)[:, :, None]
        torque += (null.transpose(0, 2, 1) @ posture)[:, :, 0]
        torque += d.qfrc_bias[self._dofs]  # gravity and Coriolis, as robosuite compensates them
        d.ctrl[self._acts] = torque  # MuJoCo clips to the motors' ctrlrange (the Panda's torque limits)
