"""Scripted expert motions shared by the bimanual tasks and their single-arm pretraining counterparts.

Each function returns one arm's sequence of keyframe actions (world frame); a task zips the sequences of
its arms into keyframes. Sharing them keeps a single-arm skill and its use inside a bimanual task identical.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.oven import (
    DOOR_THICKNESS,
    HANDLE_HEIGHT,
    HANDLE_OFFSET,
    HANDLE_RADIUS,
    PLINTH,
    TAB_HALF,
    TAB_X,
    TRAY_FLOOR_HALF,
    TRAY_HALF,
    OvenFrame,
    door_point,
)
from bimanualshift.sim.props.rope import rope_end_grasp, rope_ends
from bimanualshift.sim.props.sweeping import (
    BRUSH_HEAD_HALF,
    BRUSH_STICK_TOP,
    DIRT_HALF,
    HANDLE_GRASP_X,
    HANDLE_Z,
)
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, down_quat

# ---- oven door and tray ---------------------------------------------------------------------------------
HOOK_OUT = DOOR_THICKNESS + (HANDLE_OFFSET - HANDLE_RADIUS) / 2  # between the door and its handle bar
HOOK_ALONG = HANDLE_HEIGHT - 0.01  # grip site 1 cm below the bar: the closed fingertips reach 2 cm below it
PULL_ANGLES = np.deg2rad([10, 20, 28])  # past ~10 degrees the door falls open by itself
TAB_GRASP_Z = PLINTH + 2 * TRAY_FLOOR_HALF + 2 * TAB_HALF[2] - 0.012  # pads over the tab's upper part
TAB_PITCH = np.deg2rad(45)
TRAY_OUT_X = -TRAY_HALF[0] - 0.04  # tray centre when out: its back edge 4 cm in front of the mouth


def open_oven_door(frame: OvenFrame, hook_y: float) -> list[ArmAction]:
    """Hook the closed fingers behind the handle bar, pull the door down along its arc until it falls open
    by itself, and unhook up along the door."""
    quat = down_quat(frame.yaw)

    def door(angle: float, lift: float = 0.0) -> ArmAction:
        p = door_point(angle, HOOK_ALONG + lift, HOOK_OUT)
        return ArmAction(frame.to_world(p + [0.0, hook_y, 0.0]), quat, 0.0, 1.0)

    return [door(0.0, 0.10), door(0.0), *(door(a) for a in PULL_ANGLES), door(PULL_ANGLES[-1], 0.08)]


def pull_tray_out(frame: OvenFrame, tray_world: np.ndarray, further: float = 0.0) -> list[ArmAction]:
    """Reach the tray's tab from the front (the oven's ceiling is in the way from above) with the hand
    pitched towards the oven, pinch it, slide the tray out onto the open door (``further`` past the usual stop),
    let go and lift."""
    tray = frame.to_local(tray_world)
    tab = np.array([tray[0] + TAB_X, tray[1], TAB_GRASP_Z])
    out = tab + [TRAY_OUT_X - tray[0] - further, 0.0, 0.0]
    # Pitched so the wrist stays below-and-outside the ceiling; the fingers still open across the tab.
    quat = (frame.rotation * Rotation.from_euler("y", -TAB_PITCH) * frame.rotation.inv()
            * Rotation.from_quat(down_quat(frame.yaw))).as_quat()

    def at(local: np.ndarray, gripper: float) -> ArmAction:
        return ArmAction(frame.to_world(local), quat, gripper, 1.0)

    return [at(tab + [-0.12, 0.0, 0.04], 1.0), at(tab + [-0.12, 0.0, 0.0], 1.0), at(tab, 1.0), at(tab, 0.0),
            at(out + [0.0, 0.0, 0.01], 0.0), at(out + [0.0, 0.0, 0.01], 1.0), at(out + [0.0, 0.0, 0.12], 1.0)]


def hover(frame: OvenFrame, local: np.ndarray, gripper: float) -> ArmAction:
    """Stay out of the way at a point given in the oven's frame."""
    return ArmAction(frame.to_world(local), down_quat(frame.yaw), gripper, 1.0)


# ---- dustpan, brush and dirt ----------------------------------------------------------------------------
HEAD_CLEARANCE = 0.005  # brush head bottom above the table while sweeping
STICK_GRASP_BELOW_TOP = 0.03  # as low as the fingers reach: a short lever for the push to tilt the brush


def body_pose(sim: SimHandle, body: str) -> tuple[np.ndarray, Rotation]:
    b = sim.body_id(body)
    return sim.data.xpos[b].copy(), Rotation.from_matrix(sim.data.xmat[b].reshape(3, 3))


def hold_dustpan(sim: SimHandle, pan: str, steps: int) -> list[ArmAction]:
    """Pinch the dustpan's handle bar (fingers across it) and hold it for the rest of ``steps`` keyframes."""
    mouth, rotation = body_pose(sim, pan)
    x_axis = rotation.apply([1.0, 0.0, 0.0])
    yaw = float(np.arctan2(x_axis[1], x_axis[0]))
    handle = mouth + rotation.apply([HANDLE_GRASP_X, 0.0, HANDLE_Z - 0.004])
    quat = down_quat(yaw)  # fingers open along the pan's y: across the bar
    frames = [ArmAction(handle + [0, 0, 0.08], quat, 1.0, 1.0), ArmAction(handle, quat, 1.0, 1.0)]
    frames += [ArmAction(handle, quat, 0.0, 1.0)] * (steps - len(frames))
    return frames


def sweep_into_dustpan(sim: SimHandle, brush: str, pan: str, dirt: tuple[str, ...]) -> list[ArmAction]:
    """Pick the brush by its stick, set the head down behind the dirt square to the pan's mouth and push
    everything into the pan."""
    mouth, pan_rot = body_pose(sim, pan)
    out = pan_rot.apply([1.0, 0.0, 0.0])
    pan_yaw = float(np.arctan2(out[1], out[0]))
    brush_pos, brush_rot = body_pose(sim, brush)
    stick = np.r_[brush_pos[:2], TABLE_TOP_Z + BRUSH_STICK_TOP - STICK_GRASP_BELOW_TOP]
    pick = down_quat(brush_rot.as_euler("xyz")[2])
    # With the brush held as picked, a wrist yaw of pan_yaw + 90 degrees turns the head square to the stroke.
    sweep = down_quat(pan_yaw + np.pi / 2)
    farthest = max(float(np.dot(sim.body_pos(d) - mouth, out)) for d in dirt)
    start = mouth + out * (farthest + DIRT_HALF + BRUSH_HEAD_HALF[1] + 0.03)
    end = mouth - out * (BRUSH_HEAD_HALF[1] + 0.035)
    z = TABLE_TOP_Z + HEAD_CLEARANCE + (stick[2] - TABLE_TOP_Z)

    def at(xy: np.ndarray, height: float, quat: np.ndarray, gripper: float) -> ArmAction:
        return ArmAction(np.r_[xy[:2], height], quat, gripper, 1.0)

    return [at(stick, stick[2] + 0.08, pick, 1.0), at(stick, stick[2], pick, 1.0), at(stick, stick[2], pick, 0.0),
            at(stick, stick[2] + 0.06, pick, 0.0), at(start, z + 0.05, sweep, 0.0), at(start, z, sweep, 0.0),
            at(end, z, sweep, 0.0), at(end, z + 0.06, sweep, 0.0)]


# ---- rope --------------------------------------------------------------------------------------------------
ROPE_GRASP_Z = TABLE_TOP_Z + 0.012  # gripper site over a rope lying on the table: pads around it, tips clear
ROPE_CARRY_Z = TABLE_TOP_Z + 0.06


def carry_rope_end(sim: SimHandle, rope: str, head: bool, target: np.ndarray) -> list[ArmAction]:
    """Pinch one end of the rope across its direction, carry that end onto ``target`` (xy), let go."""
    point, direction = rope_end_grasp(sim, rope, head=head)
    end = rope_ends(sim, rope)[0 if head else 1]
    drop = np.asarray(target)[:2] + (point[:2] - end[:2])  # so the end itself lands on the target
    quat = down_quat(direction)

    def at(xy: np.ndarray, z: float, gripper: float) -> ArmAction:
        return ArmAction(np.r_[xy, z], quat, gripper, 1.0)

    grasp = point[:2]
    return [at(grasp, ROPE_GRASP_Z + 0.08, 1.0), at(grasp, ROPE_GRASP_Z, 1.0), at(grasp, ROPE_GRASP_Z, 0.0),
            at(grasp, ROPE_CARRY_Z, 0.0), at(drop, ROPE_CARRY_Z, 0.0), at(drop, ROPE_GRASP_Z + 0.01, 0.0),
            at(drop, ROPE_GRASP_Z + 0.01, 1.0), at(drop, ROPE_CARRY_Z, 1.0)]


def zip_arms(**sequences: list[ArmAction]) -> list[Keyframe]:
    """Keyframes from per-arm sequences; a shorter sequence holds its last action."""
    n = max(len(s) for s in sequences.values())
    return [{arm: seq[min(i, len(seq) - 1)] for arm, seq in sequences.items()} for i in range(n)]
