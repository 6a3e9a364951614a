"""The benchmark's named cameras: placement, and RGB / metric depth / segmentation rendering.

Rendering goes through ``mujoco.Renderer`` with anti-aliasing, shadows and reflections off: drawing the
meshes is what costs (about 20 ms per camera and pass on a 2-core CPU), so callers render only at
keyframes. Camera matrices follow ``geometry.cameras`` (OpenCV optical frame, camera-to-world).
"""

from __future__ import annotations

import atexit
import time
import weakref
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import mujoco
import numpy as np

from bimanualshift.sim.robots import PANDA, RobotSpec

WRIST_CAMERA = "robot{index}_eye_in_hand"
FOVY_DEGREES = PANDA.camera_fovy  # each robot spec names its own rig and field of view: ``sim.robots``
PRIMITIVE_SLICES, PRIMITIVE_STACKS = 14, 6


def wrist_camera_names(arm_names: tuple[str, ...]) -> dict[str, str]:
    """Benchmark wrist camera name -> MuJoCo camera name, for each arm (robot index = arm order)."""
    return {f"wrist_{arm}": WRIST_CAMERA.format(index=i) for i, arm in enumerate(arm_names)}


def default_camera_names(arm_names: tuple[str, ...], robot: RobotSpec = PANDA) -> tuple[str, ...]:
    """The cameras a robot's rig renders: its static cameras, then a wrist camera per arm where it has them."""
    return (*robot.static_cameras, *(wrist_camera_names(arm_names) if robot.wrist_cameras else ()))


def camera_xml(name: str, position: tuple[float, ...], target: tuple[float, ...],
               fovy: float = FOVY_DEGREES) -> ET.Element:
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
        fovy=str(fovy),
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


def _free_gl(gl: mujoco.GLContext, context: mujoco.MjrContext) -> None:
    gl.make_current()
    context.free()
    gl.free()


class CameraRig:
    """Renders a fixed set of MuJoCo cameras with two passes per camera.

    A colour pass draws the lit scene; a segmentation pass (flat id colours) gives the geom of every pixel and,
    from the same depth buffer, metric depth. That is the whole cost of an RGB-D + segmentation frame: MuJoCo's
    ``Renderer`` draws depth and segmentation in two separate passes of their own.
    """

    def __init__(self, model: mujoco.MjModel, names: tuple[str, ...], mujoco_names: dict[str, str],
                 height: int = 128, width: int = 128, samples: int = 0, fovy: float = FOVY_DEGREES) -> None:
        self.model = model
        self.fovy = fovy  # the robot spec's static cameras' field of view
        self.names = names
        self.mujoco_names = mujoco_names
        self.height, self.width = height, width
        # no anti-aliasing by default: 3x cheaper software rendering (calibration views ask for smooth edges)
        model.vis.quality.offsamples = samples
        # Spheres, capsules and cylinders tessellated for a 128-pixel camera (MuJoCo's default is 28 x 16; a
        # 30-segment rope then draws ~27,000 triangles).
        model.vis.quality.numslices = PRIMITIVE_SLICES
        model.vis.quality.numstacks = PRIMITIVE_STACKS
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        self._camera_ids = {
            name: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, self.mujoco_names.get(name, name))
            for name in names
        }
        missing = [name for name, cam in self._camera_ids.items() if cam < 0]
        if missing:
            raise KeyError(f"camera(s) {missing} are not in the scene")
        # The OpenGL context (and the model's meshes uploaded into it, ~0.6 s) is made at the first render: an
        # environment that is only reset and stepped (coverage, experts without frames) never pays for it.
        self._gl: mujoco.GLContext | None = None
        self._context: mujoco.MjrContext | None = None
        self._release: weakref.finalize | None = None
        self._closed = False
        self._scene = mujoco.MjvScene(model, maxgeom=10_000)
        # a flex (a cloth) has no geoms: its pixels are labelled as the invisible geom "<flex>_proxy" where the task
        # gives one, so the cloth segments as that geom's object
        flex_names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_FLEX, f) for f in range(model.nflex)]
        self._flex_proxy = {f: g for f, name in enumerate(flex_names)
                            if (g := mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"{name}_proxy")) >= 0}
        for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION,
                     mujoco.mjtRndFlag.mjRND_SKYBOX):
            self._scene.flags[flag] = 0
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self.option = mujoco.MjvOption()
        self.option.geomgroup[:] = 0
        self.option.geomgroup[1] = 1  # visual geoms only (robosuite's collision geoms are group 0)
        self.option.sitegroup[:] = 0
        # OpenGL's reversed-z depth buffer -> metres (as mujoco.Renderer converts it)
        extent = model.stat.extent
        near, far = np.float32(model.vis.map.znear * extent), np.float32(model.vis.map.zfar * extent)
        c = -(far + near) / (far - near)
        self._depth_c = float(np.float32(-0.5) * c - np.float32(0.5))
        self._depth_d = float(np.float32(-0.5) * (-(np.float32(2) * far * near) / (far - near)))

    def intrinsics(self) -> np.ndarray:
        # One fovy for every camera, the static cameras'; MuJoCo's pixels are square. (robosuite draws the Panda's
        # wrist cameras at 75 degrees: their back-projection with this value is off, and is kept as every recorded
        # result ran it until that is re-measured.)
        f = 0.5 * self.height / np.tan(np.deg2rad(self.fovy) / 2)
        return np.array([[f, 0, self.width / 2], [0, f, self.height / 2], [0, 0, 1]], dtype=np.float64)

    def extrinsics(self, data: mujoco.MjData, name: str) -> np.ndarray:
        cam = data.camera(self.mujoco_names.get(name, name))
        out = np.eye(4)
        # MuJoCo cameras look along -z with y up; OpenCV's optical frame looks along +z with y down.
        out[:3, :3] = cam.xmat.reshape(3, 3) @ np.diag([1.0, -1.0, -1.0])
        out[:3, 3] = cam.xpos
        return out

    def _open(self) -> mujoco.GLContext:
        if self._closed:
            raise RuntimeError("this camera rig was closed; create a new environment to render")
        if self._gl is None:
            gl = mujoco.GLContext(self.width, self.height)
            gl.make_current()
            self._context = mujoco.MjrContext(self.model, mujoco.mjtFontScale.mjFONTSCALE_150)
            mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._context)
            self._context.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
            self._gl = gl
            # Freed by close(), or when the rig is collected, or at exit. The finaliser holds the contexts, not the
            # rig: an exit hook on ``self.close`` kept every rig (and its model) alive for the whole process,
            # ~135 MB per environment created. At exit it runs from a hook registered after the context was made,
            # so before the one with which mujoco terminates the EGL display (exit hooks run last-registered first).
            self._release = weakref.finalize(self, _free_gl, gl, self._context)
            self._release.atexit = False
            atexit.register(self._release)
        return self._gl

    def _update_scene(self, data: mujoco.MjData, name: str) -> None:
        self._open().make_current()  # several environments (each with its own context) may share a process
        self._camera.fixedcamid = self._camera_ids[name]
        mujoco.mjv_updateScene(self.model, data, self.option, None, self._camera, mujoco.mjtCatBit.mjCAT_ALL,
                               self._scene)

    def _colour_pass(self) -> np.ndarray:
        rgb = np.empty((self.height, self.width, 3), np.uint8)
        mujoco.mjr_render(self._rect, self._scene, self._context)
        mujoco.mjr_readPixels(rgb, None, self._rect, self._context)
        return np.ascontiguousarray(rgb[::-1])  # OpenGL's rows run bottom-up; consumers want positive strides

    def _segmentation_pass(self) -> tuple[np.ndarray, np.ndarray]:
        """(metric depth, geom id per pixel or -1) from one flat-colour pass."""
        flags = self._scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 1
        ids = np.empty((self.height, self.width, 3), np.uint8)
        zbuf = np.empty((self.height, self.width), np.float32)
        try:
            mujoco.mjr_render(self._rect, self._scene, self._context)
            mujoco.mjr_readPixels(ids, zbuf, self._rect, self._context)
        finally:
            flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 0
        depth = (self._depth_d / (zbuf[::-1].astype(np.float64) + self._depth_c)).astype(np.float32)
        segid = ids[::-1].astype(np.int32)
        segid = segid[..., 0] + (segid[..., 1] << 8) + (segid[..., 2] << 16)  # 0 = background, else segid + 1
        lookup = np.full(self._scene.ngeom + 1, -1, np.int32)
        for g in self._scene.geoms[: self._scene.ngeom]:
            if g.segid >= 0 and g.objtype == mujoco.mjtObj.mjOBJ_GEOM:
                lookup[g.segid + 1] = g.objid
            elif g.segid >= 0 and g.objtype == mujoco.mjtObj.mjOBJ_FLEX and g.objid in self._flex_proxy:
                lookup[g.segid + 1] = self._flex_proxy[g.objid]
        return depth, lookup[np.minimum(segid, self._scene.ngeom)]

    def render(self, data: mujoco.MjData, depth_and_segmentation: bool = True,
               timings: dict[str, list[float]] | None = None) -> dict[str, CameraFrame]:
        """Every camera's frame; ``timings``, if given, collects milliseconds per ``camera/pass``."""
        frames: dict[str, CameraFrame] = {}
        clock = _PassClock(timings)
        for name in self.names:
            clock.start()
            self._update_scene(data, name)
            clock.lap(f"{name}/scene")
            rgb = self._colour_pass()
            clock.lap(f"{name}/rgb")
            if depth_and_segmentation:
                depth, geom = self._segmentation_pass()
                clock.lap(f"{name}/depth_segmentation")
            else:
                depth = np.zeros(rgb.shape[:2], np.float32)
                geom = np.full(rgb.shape[:2], -1, np.int32)
            frames[name] = CameraFrame(rgb, depth, geom, self.intrinsics(), self.extrinsics(data, name))
        return frames

    def render_rgb(self, data: mujoco.MjData, name: str) -> np.ndarray:
        """One camera's colour image only (cheap enough for video frames)."""
        self._update_scene(data, name)
        return self._colour_pass()

    def close(self) -> None:
        self._closed = True
        if self._release is not None:
            self._release()  # runs once; later calls do nothing
            atexit.unregister(self._release)
        self._gl = self._context = None
