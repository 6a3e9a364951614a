"""Arm control at physics speed: robosuite's operational-space law, computed once per control step, held by
MuJoCo joint servos through the substeps.

robosuite evaluates its OSC in Python at every 2 ms physics substep, which costs several times the physics it
drives. Here Python runs once per 50 ms control step. It computes the OSC's torque there, as robosuite does
(tau = J^T Lambda kp e plus the nullspace pull to the home posture, Lambda the operational-space inertia), and
hands it to position servos inside ``mj_step``: each arm joint's motor becomes a servo whose target is
q + tau / K with K = diag(J^T Lambda kp J). At the start of the step the servo applies exactly the OSC's torque;
as the arm moves during the step the torque falls by K dq, the diagonal of how the OSC's spring itself would
change. The OSC's damping J^T Lambda kd J (diagonal, critically damped) goes into the joints' damping, which
MuJoCo's Euler integrator treats implicitly. Gravity is compensated by MuJoCo (``gravcomp`` on the robot's
bodies, as the OSC added it), torques stay within the Panda's limits (80 / 12 N m), and the grippers keep
robosuite's position servos and its ramp of 0.2 of the range per control step.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

SUBSTEPS = 25  # physics steps of 2 ms per 50 ms control step
OSC_KP = 300.0  # the Cartesian stiffness of the controller this one replaces (N/m and N m/rad)
DAMPING_RATIO = 1.0  # robosuite's OSC is critically damped
NULLSPACE_KP = 10.0  # robosuite's OSC pull towards the home posture, in the nullspace
GRIPPER_RAMP = 0.2  # robosuite's Panda gripper speed: fraction of the normalised range per control step


@dataclass
class ArmIndexes:
    """Where one arm lives in the compiled model."""

    qpos: np.ndarray  # (7,) qpos addresses of the arm joints
    dofs: np.ndarray  # (7,) dof addresses
    actuators: np.ndarray  # (7,) actuator ids (servos after conversion)
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


class ServoArms:
    """Converts the arms' motors into servos once, then sets their targets once per control step."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, arms: list[ArmIndexes]) -> None:
        self.model, self.data, self.arms = model, data, arms
        self._jacp = np.zeros((3, model.nv))
        self._jacr = np.zeros((3, model.nv))
        self._quat = np.zeros(4)
        self._err_quat = np.zeros(4)
        self._rot_err = np.zeros(3)
        self.gripper_action = np.zeros((len(arms), 2))
        self._convert(model, data)

    # ---- one-off model conversion --------------------------------------------------------------------------
    def _convert(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        if model.ngravcomp == 0:
            raise ValueError("the robots' bodies need gravcomp='1' in the scene XML (sim.scene sets it)")
        for arm in self.arms:
            for act in arm.actuators:
                joint = int(model.actuator_trnid[act, 0])
                limit = float(np.abs(model.actuator_ctrlrange[act]).max())
                model.actuator_gaintype[act] = mujoco.mjtGain.mjGAIN_FIXED
                model.actuator_biastype[act] = mujoco.mjtBias.mjBIAS_AFFINE
                model.actuator_gainprm[act, :] = 0.0
                model.actuator_biasprm[act, :] = 0.0
                model.actuator_ctrllimited[act] = 0  # the target may lie beyond the joint; the force is limited
                model.actuator_forcelimited[act] = 1
                model.actuator_forcerange[act] = (-limit, limit)
                model.dof_damping[model.jnt_dofadr[joint]] = 0.0
        self._mass = np.zeros((model.nv, model.nv))

    # ---- per episode ------------------------------------------------------------------------------------------
    def reset(self) -> None:
        """Hold the current joints, grippers open (call after the joints are placed)."""
        for i, arm in enumerate(self.arms):
            self.data.ctrl[arm.actuators] = self.data.qpos[arm.qpos]  # zero torque until the first command
            self.gripper_action[i] = (1.0, -1.0)
            self._apply_gripper(i)

    # ---- per control step ---------------------------------------------------------------------------------
    def command(self, positions: np.ndarray, quats_wxyz: np.ndarray, gripper_open: np.ndarray) -> None:
        """Set every arm's servo for the next control step from its commanded world pose."""
        m, d = self.model, self.data
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_crb(m, d)
        mujoco.mj_fullM(m, self._mass, d.qM)
        kd = 2.0 * DAMPING_RATIO * np.sqrt(OSC_KP)
        for i, arm in enumerate(self.arms):
            mujoco.mj_jacSite(m, d, self._jacp, self._jacr, arm.site)
            jac = np.vstack([self._jacp[:, arm.dofs], self._jacr[:, arm.dofs]])
            mujoco.mju_mat2Quat(self._quat, d.site_xmat[arm.site])
            mujoco.mju_negQuat(self._err_quat, self._quat)
            mujoco.mju_mulQuat(self._err_quat, quats_wxyz[i], self._err_quat)
            mujoco.mju_quat2Vel(self._rot_err, self._err_quat, 1.0)
            error = np.r_[positions[i] - d.site_xpos[arm.site], self._rot_err]
            q = d.qpos[arm.qpos]
            mass = self._mass[np.ix_(arm.dofs, arm.dofs)]
            mass_inv = np.linalg.inv(mass)
            # robosuite's OSC with position and orientation uncoupled: one operational-space inertia each.
            jp, jr = jac[:3], jac[3:]
            lam_p = np.linalg.pinv(jp @ mass_inv @ jp.T)
            lam_r = np.linalg.pinv(jr @ mass_inv @ jr.T)
            torque = OSC_KP * (jp.T @ (lam_p @ error[:3]) + jr.T @ (lam_r @ error[3:]))
            # Its nullspace pull to the home posture (robosuite's kp_null = 10).
            lam = np.linalg.pinv(jac @ mass_inv @ jac.T)
            null = np.eye(len(q)) - (mass_inv @ jac.T @ lam @ jac).T
            torque += null @ (mass @ (NULLSPACE_KP * (arm.home - q)))
            # The OSC's torque is linear in the joints near q: tau(q + dq) = tau - S dq. Its servo target is
            # where that spring rests, q + S^-1 tau; the servo's own stiffness and damping are the diagonals of
            # the OSC's, so in free space and against contact it pushes as the OSC would.
            spring = OSC_KP * (jp.T @ lam_p @ jp + jr.T @ lam_r @ jr) + NULLSPACE_KP * null @ mass
            rest = np.linalg.lstsq(spring, torque, rcond=1e-6)[0]
            stiffness = np.diag(spring).copy()
            damping = (kd / OSC_KP) * np.diag(spring - NULLSPACE_KP * null @ mass) \
                + 2.0 * np.sqrt(NULLSPACE_KP) * np.diag(null @ mass)
            m.actuator_gainprm[arm.actuators, 0] = stiffness
            m.actuator_biasprm[arm.actuators, 1] = -stiffness
            m.dof_damping[arm.dofs] = damping
            d.ctrl[arm.actuators] = q + rest
            direction = -1.0 if gripper_open[i] > 0.5 else 1.0  # robosuite's convention: -1 opens
            self.gripper_action[i] = np.clip(self.gripper_action[i] + np.array([-1.0, 1.0]) * GRIPPER_RAMP
                                             * direction, -1.0, 1.0)
            self._apply_gripper(i)

    def _apply_gripper(self, i: int) -> None:
        acts = self.arms[i].gripper_actuators
        low, high = self.model.actuator_ctrlrange[acts, 0], self.model.actuator_ctrlrange[acts, 1]
        self.data.ctrl[acts] = 0.5 * (high + low) + 0.5 * (high - low) * self.gripper_action[i]

    def step(self) -> None:
        mujoco.mj_step(self.model, self.data, SUBSTEPS)
