"""Applying ``Perturbations`` to a compiled scene (appearance, cameras) and to an episode (mirrored layout)."""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.perturbations import Perturbations
from bimanualshift.sim.robots import RLBENCH2_CAMERAS

TABLE_COLOUR = (0.15, 0.2, 0.35)
FLOOR_COLOUR = (0.1, 0.1, 0.1)


def apply_to_model(model: mujoco.MjModel, p: Perturbations,
                   static_cameras: tuple[str, ...] = tuple(RLBENCH2_CAMERAS)) -> None:
    """Change lights, surfaces and the poses of ``static_cameras`` (the robot spec's) once, after the scene is
    compiled."""
    if p.lighting > 0:
        dim = 1.0 - 0.7 * p.lighting
        warm = np.array([1.0, 0.85, 0.6]) ** p.lighting
        model.light_diffuse[:] = model.light_diffuse * dim * warm
        model.vis.headlight.diffuse[:] = np.asarray(model.vis.headlight.diffuse) * dim * warm
        model.vis.headlight.ambient[:] = np.asarray(model.vis.headlight.ambient) * dim * warm
    if p.glare:
        # Over-bright lights with full specular highlights: shiny surfaces burn out to white in places.
        model.light_diffuse[:] = np.clip(model.light_diffuse * 2.2, 0.0, 3.0)
        model.light_specular[:] = 1.0
        model.vis.headlight.specular[:] = 1.0
        model.mat_specular[:] = 1.0
        model.mat_shininess[:] = 1.0
        model.mat_reflectance[:] = np.maximum(model.mat_reflectance, 0.3)
    if p.table_texture:
        for g in range(model.ngeom):
            body = model.body(int(model.body_rootid[model.geom_bodyid[g]])).name
            name = model.geom(g).name
            if body == "table" and model.geom_group[g] == 1:
                model.geom_matid[g] = -1
                model.geom_rgba[g, :3] = TABLE_COLOUR
            elif name == "floor":
                model.geom_matid[g] = -1
                model.geom_rgba[g, :3] = FLOOR_COLOUR
    if p.camera_shift_m > 0 or p.camera_rotate_deg > 0:
        rng = np.random.default_rng(p.seed)
        for name in static_cameras:
            cam = model.camera(name).id
            direction = rng.normal(size=3)
            model.cam_pos[cam] += p.camera_shift_m * direction / np.linalg.norm(direction)
            axis = rng.normal(size=3)
            turn = Rotation.from_rotvec(np.deg2rad(p.camera_rotate_deg) * axis / np.linalg.norm(axis))
            quat = turn * Rotation.from_quat(np.roll(model.cam_quat[cam], -1))
            model.cam_quat[cam] = np.roll(quat.as_quat(), 1)


def _reflect_wxyz(q: np.ndarray) -> np.ndarray:
    """The rotation M R M for the mirror M = diag(1, -1, 1), as a (w, x, y, z) quaternion."""
    return np.array([q[0], -q[1], q[2], -q[3]])


def _half_turned_wxyz(q: np.ndarray) -> np.ndarray:
    """``q`` followed by half a turn about the body's own vertical axis."""
    turned = Rotation.from_quat(np.roll(q, -1)) * Rotation.from_euler("z", np.pi)
    return np.roll(turned.as_quat(), 1)


def mirror_bodies(model: mujoco.MjModel, data: mujoco.MjData, roots: list[int], half_turned: tuple[int, ...] = ()
                  ) -> None:
    """Mirror the given root bodies (and everything hanging from them) across the x-z plane.

    A rigid body can only be turned, not reflected: each keeps its own shape and is turned as its mirror image is.
    That is the reflected rotation for a body symmetric across its own x-z plane, and the same plus half a turn for
    the ``half_turned`` roots, symmetric across their own y-z plane instead (a toaster's handle and lever ends
    change places in its mirror image)."""
    for body in range(1, model.nbody):
        if int(model.body_rootid[body]) not in roots:
            continue
        turn = int(model.body_rootid[body]) in half_turned
        if model.body_parentid[body] == 0:
            model.body_pos[body, 1] *= -1
            model.body_quat[body] = _reflect_wxyz(model.body_quat[body])
            if turn and model.body_jntnum[body] == 0:  # fixed to the table: its placement is its pose
                model.body_quat[body] = _half_turned_wxyz(model.body_quat[body])
        for j in range(model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body]):
            adr, kind = model.jnt_qposadr[j], model.jnt_type[j]
            if kind == mujoco.mjtJoint.mjJNT_FREE:
                data.qpos[adr + 1] *= -1
                data.qpos[adr + 3 : adr + 7] = _reflect_wxyz(data.qpos[adr + 3 : adr + 7])
                if turn:
                    data.qpos[adr + 3 : adr + 7] = _half_turned_wxyz(data.qpos[adr + 3 : adr + 7])
            elif kind == mujoco.mjtJoint.mjJNT_BALL:
                data.qpos[adr : adr + 4] = _reflect_wxyz(data.qpos[adr : adr + 4])
            elif kind == mujoco.mjtJoint.mjJNT_SLIDE and abs(model.jnt_axis[j][1]) > 0.5:
                data.qpos[adr] *= -1  # a slide along y (a cloth's vertex) moves the other way in the mirror
    mujoco.mj_forward(model, data)
