"""End-effector poses from joint positions, for datasets that record joints only (most LeRobot datasets).

The robot is a MuJoCo model (MJCF, or a URDF MuJoCo can load) whose joints carry the dataset's state names
(``left_joint1`` ...) and which has one site per arm at its end effector (``<arm>_ee`` by default). Forward
kinematics is MuJoCo's own (``mj_kinematics``); the model's world frame is the poses' world frame.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np


class KinematicsModel:
    def __init__(self, path: str | Path, ee_site: str = "{arm}_ee") -> None:
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"--kinematics {path}: no such model file (an MJCF or URDF of the robot)")
        try:
            self.model = mujoco.MjModel.from_xml_path(str(path))
        except ValueError as err:
            raise ValueError(f"--kinematics {path}: MuJoCo cannot load it: {err}") from None
        self.data = mujoco.MjData(self.model)
        self.ee_site = ee_site
        self.joint_names = [self.model.joint(i).name for i in range(self.model.njnt)]

    def ee_poses(self, state: np.ndarray, names: list[str], arms: list[str]) -> np.ndarray:
        """(frames, arms, 7) world poses x y z qx qy qz qw from (frames, len(names)) joint states; a state name
        that is no joint of the model (a gripper) is ignored."""
        columns = {n: i for i, n in enumerate(names)}
        joints = [j for j in self.joint_names if j in columns]
        missing = [j for j in self.joint_names if j not in columns and self.model.joint(j).type != 0]
        if not joints:
            raise ValueError(f"no state name matches a joint of the kinematics model (joints: {self.joint_names[:8]}"
                             f"; state: {names[:8]}): name the model's joints as the dataset's state")
        if missing:
            raise ValueError(f"the dataset's state lacks the model's joints {missing}")
        sites = []
        for arm in arms:
            name = self.ee_site.format(arm=arm)
            sid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, name)
            if sid < 0:
                raise ValueError(f"the kinematics model has no site {name!r} at {arm}'s end effector")
            sites.append(sid)
        out = np.zeros((len(state), len(arms), 7), np.float32)
        quat = np.empty(4)
        for t, row in enumerate(np.asarray(state, np.float64)):
            for j in joints:
                self.data.qpos[self.model.jnt_qposadr[self.model.joint(j).id]] = row[columns[j]]
            mujoco.mj_kinematics(self.model, self.data)
            for a, sid in enumerate(sites):
                mujoco.mju_mat2Quat(quat, self.data.site_xmat[sid])
                out[t, a] = np.r_[self.data.site_xpos[sid], np.roll(quat, -1)]
        return out
