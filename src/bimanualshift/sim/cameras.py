"""The benchmark's named cameras: placement, and RGB / metric depth / segmentation rendering.

Rendering goes through ``mujoco.Renderer`` with anti-aliasing, shadows and reflections off: drawing the
meshes is what costs (about 20 ms per camera and pass on a 2-core CPU), so callers render only at
keyframes. Camera matrices follow ``geometry.cameras`` (OpenCV optical frame, camera-to-world).
"""

from __future__ import annotations

import atexit
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import mujoco
import numpy as np

STATIC_CAMERAS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    # name: (position, look-at point), world frame; table top at z = 0.8, robots at x = -0.56.
    "front": ((0.95, 0.0, 1.4), (0.0, 0.0, 0.85)),
    "overhead": ((0.15, 0.0, 2.05), (0.0, 0.0, 0.8)),
    "over_shoulder_left": ((-0.3, 0.95, 1.5), (0.05, 0.0, 0.8)),
    "over_shoulder_right": ((-0.3, -0.95, 1.5), (0.05, 0.0, 0.8)),
}
WRIST_CAMERA = "robot{index}_eye_in_hand"
FOVY_DEGREES = 60.0


def wrist_camera_names(arm_names: tuple[str, ...]) -> dict[str, str]:
    """Benchmark wrist camera name -> MuJoCo camera name, for each arm (robot index = arm order)."""
    return {f"wrist_{arm}": WRIST_CAMERA.format(index=i) for i, arm in enumerate(arm_names)}


def default_camera_names(arm_names: tuple[str, ...]) -> tuple[str, ...]:
    return (*STATIC_CAMERAS, *wrist_camera_names(arm_names))


def camera_xml(name: str, position: tuple[float, ...], target: tuple[float, ...]) -> ET.Element:
    pos, tgt = np.asarray(position, float), np.asarray(target, float)
    forward = (tgt - pos) / np.linalg.norm(tgt - pos)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    return ET.Element(
        "camera",
        name=name,
        mode="fixed",
        pos=" ".join(f"{v:.4f}" for v in pos),
        xyaxes=" ".join(f"{v:.5f}" for v in (*right, *up)),
        fovy=str(FOVY_DEGREES),
    )


@dataclass
class CameraFrame:
    rgb: np.ndarray  # (H, W, 3) uint8
    depth: np.ndarray  # (H, W) float32 metres along the optical axis
    geom: np.ndarray  # (H, W) int32 MuJoCo geom id, -1 for background
    intrinsics: np.ndarray  # (3, 3)
    extrinsics: np.ndarray  # (4, 4) camera-to-world, OpenCV optical frame


class _PassClock:
    """Milliseconds between laps, appended to ``timings[key]`` (a no-op without ``timings``)."""

    def __init__(self, timings: dict[str, list[float]] | None) -> None:
        self.timings = timings
        self.t = 0.0

    def start(self) -> None:
        if self.timings is not None:
            self.t = time.perf_counter()

    def lap(self, key: str) -> None:
        if self.timings is not None:
            now = time.perf_counter()
            self.timings.setdefault(key, []).append(1000 * (now - self.t))
            self.t = now


class CameraRig:
    """Renders a fixed set of MuJoCo cameras."""

    def __init__(self, model: mujoco.MjModel, names: tuple[str, ...], mujoco_names: dict[str, str],
                 height: int = 128, width: int = 128) -> None:
        self.model = model
        self.names = names
        self.mujoco_names = mujoco_names
        self.height, self.width = height, width
        model.vis.quality.offsamples = 0  # no anti-aliasing: 3x cheaper software rendering
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        self.renderer: mujoco.Renderer | None = mujoco.Renderer(model, height, width)
        atexit.register(self.close)  # free the GL context before interpreter teardown breaks EGL calls
        for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION,
                     mujoco.mjtRndFlag.mjRND_SKYBOX):
            self.renderer.scene.flags[flag] = 0
        self.option = mujoco.MjvOption()
        self.option.geomgroup[:] = 0
        self.option.geomgroup[1] = 1  # visual geoms only (robosuite's collision geoms are group 0)
        self.option.sitegroup[:] = 0
        for name in names:
            if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, self.mujoco_names.get(name, name)) < 0:
                raise KeyError(f"camera {name!r} is not in the scene")

    def intrinsics(self) -> np.ndarray:
        # One fovy for every camera; MuJoCo's pixels are square.
        f = 0.5 * self.height / np.tan(np.deg2rad(FOVY_DEGREES) / 2)
        return np.array([[f, 0, self.width / 2], [0, f, self.height / 2], [0, 0, 1]], dtype=np.float64)

    def extrinsics(self, data: mujoco.MjData, name: str) -> np.ndarray:
        cam = data.camera(self.mujoco_names.get(name, name))
        out = np.eye(4)
        # MuJoCo cameras look along -z with y up; OpenCV's optical frame looks along +z with y down.
        out[:3, :3] = cam.xmat.reshape(3, 3) @ np.diag([1.0, -1.0, -1.0])
        out[:3, 3] = cam.xpos
        return out

    def render(self, data: mujoco.MjData, depth_and_segmentation: bool = True,
               timings: dict[str, list[float]] | None = None) -> dict[str, CameraFrame]:
        """Every camera's frame; ``timings``, if given, collects milliseconds per ``camera/pass``."""
        frames: dict[str, CameraFrame] = {}
        r = self.renderer
        if r is None:
            raise RuntimeError("this camera rig was closed; create a new environment to render")
        clock = _PassClock(timings)
        for name in self.names:
            cam = self.mujoco_names.get(name, name)
            clock.start()
            r.update_scene(data, camera=cam, scene_option=self.option)
            clock.lap(f"{name}/scene")
            rgb = r.render().copy()
            clock.lap(f"{name}/rgb")
            depth = np.zeros(rgb.shape[:2], np.float32)
            geom = np.full(rgb.shape[:2], -1, np.int32)
            if depth_and_segmentation:
                r.enable_depth_rendering()
                depth = r.render().astype(np.float32)
                r.disable_depth_rendering()
                clock.lap(f"{name}/depth")
                r.enable_segmentation_rendering()
                seg = r.render()
                r.disable_segmentation_rendering()
                geom = np.where(seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM), seg[..., 0], -1).astype(np.int32)
                clock.lap(f"{name}/segmentation")
            frames[name] = CameraFrame(rgb, depth, geom, self.intrinsics(), self.extrinsics(data, name))
        return frames

    def render_rgb(self, data: mujoco.MjData, name: str) -> np.ndarray:
        """One camera's colour image only (cheap enough for video frames)."""
        if self.renderer is None:
            raise RuntimeError("this camera rig was closed; create a new environment to render")
        self.renderer.update_scene(data, camera=self.mujoco_names.get(name, name), scene_option=self.option)
        return self.renderer.render().copy()

    def close(self) -> None:
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None
