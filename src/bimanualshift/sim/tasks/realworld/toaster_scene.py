"""What the toaster tasks share (Toaster Activation, Toasting Completion, the long Insert-Press-Grasp-Place task and
their single-arm skills): where things stand, the latch, and each arm's keyframes.

Layout of the bimanual scenes: the toaster stands left of the middle, its handle towards the left arm and its
lever towards the right arm; the slice's rack stands front right, the plate back right. The left arm holds the
toaster; the right arm inserts, presses, grasps and places. A left-right exchange mirrors all of it, the toaster
turned round, and the two arms change roles (``roles``)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.plate import plate_floor_top
from bimanualshift.sim.props.toaster import (
    BREAD,
    BREAD_COLOUR,
    HALF_Y,
    HANDLE,
    HEIGHT,
    LEVER,
    LEVER_TOP,
    LEVER_TRAVEL,
    SLOT_FLOOR,
    TOAST_COLOUR,
    hold_latch,
    to_world,
    toaster_upright,
    yaw_of,
)
from bimanualshift.sim.task import ArmAction, SimHandle, Task
from bimanualshift.sim.tasks.realworld.block_threading import across, grasp_from_above, hand_down, shorter_turn

TOASTER_REGION = ((-0.08, 0.0), (0.02, 0.07))
RACK_REGION = ((0.0, 0.08), (-0.26, -0.20))
PLATE_REGION = ((-0.18, -0.12), (-0.30, -0.25))  # its rim clear of the lever by 3 cm at least
PLATE_RADIUS = 0.07
YAW = np.pi / 16
STILL_WITHIN = 0.03  # metres the toaster may move while it is worked on
# degrees it may rock while it is worked on: held, the scripted press rocks it 2-3; unheld, 12-13
STEADY_WITHIN_DEG = 6.0
HANDLE_GRIP_OUT = 0.035  # the hand grips the handle this far out from the toaster's end
SITE_BELOW_TOP = 0.02  # a hand grips the slice with its site this far below the slice's top edge
LIFT = 0.17  # the slice's bottom this far above the table while carried (clear of the toaster's 12 cm)
LEVER_PRESS_BELOW = 0.01  # the press target this far beyond the lever's full travel


class ToasterTask(Task):
    """The hooks the toaster tasks share: the robot, the latch and the toast's colour, and the toaster's pose."""

    robot = "ur5e"
    toaster_mounted: ClassVar[bool] = False  # the single-arm skills' toaster is fixed to the table
    mirrored_by_half_turn = ("toaster",)  # its mirror image has the handle and the lever at the other ends

    def on_control_step(self, sim: SimHandle) -> None:
        # where the toaster stood: taken at the first step, after any mirrored layout has moved it
        if "toaster_start" not in self.episode:
            self.episode["toaster_start"] = [float(v) for v in sim.body_pos("toaster")[:2]]
        was = bool(self.episode.get("latched", False))
        latched = hold_latch(sim, was)
        if latched and not was and self.has_bread:
            sim.set_rgb("bread_geom", TOAST_COLOUR)  # it toasts
        self.episode["latched"] = latched
        if not self.toaster_mounted:  # how far it has rocked
            up = sim.data.xmat[sim.body_id("toaster")].reshape(3, 3)[2, 2]
            tilt = float(np.degrees(np.arccos(np.clip(up, -1.0, 1.0))))
            self.episode["max_tilt_deg"] = max(tilt, self.episode.get("max_tilt_deg", 0.0))

    @property
    def has_bread(self) -> bool:
        return "bread" in self.scene_xml()

    def paint_toaster(self, sim: SimHandle, colour: str) -> None:
        for part in ("base", "wall0", "wall1", "end0", "end1"):
            sim.set_rgb(f"toaster_{part}", self.palette[colour])
        if self.has_bread:
            sim.set_rgb("bread_geom", BREAD_COLOUR)

    def record_start(self, sim: SimHandle) -> None:
        self.episode["latched"] = False
        self.episode["max_tilt_deg"] = 0.0

    def paint_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        """One colour for the toaster; the episode's state starts here."""
        colour = self.pick_colours(rng, 1)[0]
        self.paint_toaster(sim, colour)
        self.episode = {"colour": colour}
        self.record_start(sim)

    def toaster_still(self, sim: SimHandle) -> bool:
        """The toaster stands where it stood and never rocked by more than ``STEADY_WITHIN_DEG``."""
        moved = np.linalg.norm(sim.body_pos("toaster")[:2] - np.asarray(self.episode["toaster_start"]))
        steady = self.toaster_mounted or self.episode.get("max_tilt_deg", 0.0) < STEADY_WITHIN_DEG
        return bool(moved < STILL_WITHIN and steady and toaster_upright(sim))


# Where the single-arm skills put things, from the one arm's base: as the bimanual scene puts them from the base of
# the arm that does the skill there (left holds, right inserts, presses and places), on either side of the arm.
HOLDER_TOASTER_Y = (0.23, 0.28)  # |y| of the toaster's centre, its handle towards the arm
WORKER_TOASTER_Y = (0.32, 0.37)  # |y| of the toaster's centre, its lever towards the arm
WORKER_RACK_Y = (0.04, 0.10)
WORKER_PLATE_Y = (0.0, 0.05)


def facing_yaw(rng: np.random.Generator, towards_minus_y: bool) -> float:
    """A toaster's yaw: its -y end (the lever) towards -y if ``towards_minus_y``, else turned half round."""
    return rng.uniform(-YAW, YAW) + (0.0 if towards_minus_y else np.pi)


def roles(sim: SimHandle) -> tuple[str, str]:
    """(the arm that holds the toaster, the arm that works on it): the holder is the arm on the handle's side, the
    left one unless a left-right exchange turned the toaster round."""
    handle_side = to_world(sim, "toaster", [0.0, HALF_Y, 0.0])[1] - sim.body_pos("toaster")[1]
    return ("left", "right") if handle_side > 0 else ("right", "left")


def sample_xy(rng: np.random.Generator, region: tuple[tuple[float, float], tuple[float, float]],
              side: float = 1.0, shift_y: float = 0.0) -> np.ndarray:
    """A point in ``region`` (mirrored across the table's centre line for ``side`` -1), shifted by ``shift_y``."""
    (x0, x1), (y0, y1) = region
    return np.array([rng.uniform(x0, x1), side * (rng.uniform(y0, y1) + shift_y)])


# ---- one arm's keyframes --------------------------------------------------------------------------------------
def handle_keyframes(sim: SimHandle, holds: int) -> list[ArmAction]:
    """Above the handle, grip it (fingers across it), then hold still for ``holds`` more keyframes."""
    grip = to_world(sim, "toaster", [0.0, HALF_Y + HANDLE_GRIP_OUT, HEIGHT - HANDLE[2] - 0.012])
    quat = hand_down(across(yaw_of(sim, "toaster")))
    return [*grasp_from_above(grip, quat), *[ArmAction(grip, quat, 0.0, 0.0) for _ in range(holds)]]


def lever_keyframes(sim: SimHandle) -> list[ArmAction]:
    """Gripper closed: above the lever, onto it, down through its travel, back up."""
    top = to_world(sim, "toaster", [0.0, -HALF_Y - LEVER[1], LEVER_TOP + LEVER[2]])
    quat = hand_down(across(yaw_of(sim, "toaster")))
    pressed = top - [0.0, 0.0, LEVER_TRAVEL + LEVER_PRESS_BELOW]
    return [ArmAction(top + [0, 0, 0.10], quat, 0.0, 1.0), ArmAction(top + [0, 0, 0.01], quat, 0.0, 1.0),
            ArmAction(pressed, quat, 0.0, 0.0), ArmAction(top + [0, 0, 0.08], quat, 0.0, 1.0)]


def slice_grip(centre: np.ndarray, slice_yaw: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Where a hand grips a standing slice centred at ``centre`` (fingers across its faces), how it is turned, and
    the hand's yaw."""
    yaw = across(slice_yaw)
    return np.r_[centre[:2], centre[2] + BREAD[2] - SITE_BELOW_TOP], hand_down(yaw), yaw


SITE_ABOVE_BOTTOM = 2 * BREAD[2] - SITE_BELOW_TOP  # the gripping site above the slice's bottom edge


def insert_keyframes(sim: SimHandle) -> list[ArmAction]:
    """Above the slice, grip it, lift it, over the slot, down into the slot, let go."""
    grip, quat, yaw = slice_grip(sim.body_pos("bread"), yaw_of(sim, "bread"))
    slot = to_world(sim, "toaster", [0.0, 0.0, 0.0])[:2]
    level = hand_down(shorter_turn(yaw_of(sim, "toaster") + np.pi / 2, yaw))
    over = np.r_[slot, TABLE_TOP_Z + LIFT + SITE_ABOVE_BOTTOM]
    down = np.r_[slot, TABLE_TOP_Z + SLOT_FLOOR + 0.005 + SITE_ABOVE_BOTTOM]
    lifted = np.r_[grip[:2], TABLE_TOP_Z + LIFT + SITE_ABOVE_BOTTOM]
    return [*grasp_from_above(grip, quat), ArmAction(lifted, quat, 0.0, 1.0), ArmAction(over, level, 0.0, 1.0),
            ArmAction(down, level, 0.0, 1.0), ArmAction(down, level, 1.0, 1.0)]


def slice_in_slot(sim: SimHandle) -> tuple[np.ndarray, float]:
    """Where a slice stands once let go of in the slot (its centre), and its yaw: the slot's."""
    slot = to_world(sim, "toaster", [0.0, 0.0, 0.0])
    return np.r_[slot[:2], TABLE_TOP_Z + SLOT_FLOOR + BREAD[2]], yaw_of(sim, "toaster")


def place_keyframes(sim: SimHandle, toast: tuple[np.ndarray, float]) -> list[ArmAction]:
    """Above the toast (its centre and yaw: ``toast``), grip it, lift it out of the slot, over the plate, let go."""
    grip, quat, _ = slice_grip(*toast)
    plate = sim.body_pos("plate")
    over = np.r_[plate[:2], plate_floor_top() + 0.03 + SITE_ABOVE_BOTTOM]
    lifted = np.r_[grip[:2], TABLE_TOP_Z + LIFT + SITE_ABOVE_BOTTOM]
    return [*grasp_from_above(grip, quat), ArmAction(lifted, quat, 0.0, 1.0), ArmAction(over, quat, 0.0, 1.0),
            ArmAction(over, quat, 1.0, 1.0)]


def toast_on_plate(sim: SimHandle) -> bool:
    """The slice lies or stands on the plate, let go of."""
    bread, plate = sim.body_pos("bread"), sim.body_pos("plate")
    on = np.linalg.norm(bread[:2] - plate[:2]) < PLATE_RADIUS and bread[2] < plate_floor_top() + BREAD[2] + 0.01
    return bool(on and not sim.touching_robot("bread"))
