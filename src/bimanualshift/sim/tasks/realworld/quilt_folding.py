"""Quilt folding (the paper's real-world Collaboration tier, 5 keyframes): both arms take the quilt's near corners
by their tabs, lift them, carry them over the quilt together and lay them on the far corners, then let go.
Success: each near corner within ``FOLDED_WITHIN`` of the far corner on its side, lying on the quilt (not held up).
One arm alone drags its corner diagonally and leaves the other behind."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import TABLE_TOP_Z, arms_by_side
from bimanualshift.sim.props.cloth import QUILT_RADIUS, TAB_HALF, corners, flex_id, place_quilt, quilt_xml
from bimanualshift.sim.task import ArmAction, Keyframe, SimHandle, Task, register_task
from bimanualshift.sim.tasks.realworld.block_threading import hand_down

QUILT_REGION = ((0.0, 0.05), (-0.02, 0.02))  # the quilt's middle
YAW = np.pi / 36  # the quilt turned by up to 5 degrees
LIFT = 0.10  # a tab lifted this far before it is carried: the corner comes off the table
OVER = 0.06  # carried over the far corner with the tab's foot this high above the table
# laid this far short of where the far corner first lay: lifting the near half drags the far half 2.5-3 cm back
# towards the robots (seeds 200000-3 ended 3.0-4.7 cm past the far corners when laid on their first place)
BEYOND_FAR = -0.035
LAID = 0.01  # let go of with the tab's foot this high above the quilt's far half (it drops onto it)
FOLDED_WITHIN = 0.05
LYING_WITHIN = 0.03  # a folded corner lies at most this far above the far corner it covers


def fold_keyframes(sim: SimHandle, side: str) -> list[ArmAction]:
    """One arm's five keyframes for the near corner on ``side`` (left: +y): above its tab, closed on it, lifted,
    over the far corner on that side, lowered onto it and let go of."""
    c = corners(sim)
    tab = sim.body_pos(f"quilt_tab_{side}")
    depth = c[f"far_{side}"] - c[f"near_{side}"]
    depth[2] = 0.0
    depth = depth / np.linalg.norm(depth)  # towards the far edge
    quat = hand_down(float(np.arctan2(depth[1], depth[0])) + np.pi / 2)  # fingers across the tab
    cloth = TABLE_TOP_Z + 2 * QUILT_RADIUS  # a tab's foot, on the table
    lifted = np.r_[tab[:2], tab[2] + LIFT]
    far = c[f"far_{side}"][:2] + BEYOND_FAR * depth[:2]
    over = np.r_[far, cloth + OVER + TAB_HALF[2]]
    laid = np.r_[far, cloth + 2 * QUILT_RADIUS + LAID + TAB_HALF[2]]
    return [ArmAction(tab + [0.0, 0.0, 0.08], quat, 1.0, 1.0), ArmAction(tab, quat, 0.0, 0.0),
            ArmAction(lifted, quat, 0.0, 1.0), ArmAction(over, quat, 0.0, 1.0), ArmAction(laid, quat, 1.0, 1.0)]


def corner_folded(sim: SimHandle, side: str) -> bool:
    c = corners(sim)
    near, far = c[f"near_{side}"], c[f"far_{side}"]
    return bool(np.linalg.norm(near[:2] - far[:2]) < FOLDED_WITHIN and near[2] - far[2] < LYING_WITHIN)


class QuiltTask(Task):
    """What the quilt tasks share: the robot, the scene, the instruction and the colours."""

    robot = "ur5e"

    def scene_xml(self) -> str:
        return quilt_xml()

    def instance_name(self, root_body: str) -> str:
        return "quilt" if root_body == "quilt_proxy" else root_body  # the cloth's pixels

    def instance_class(self, instance: str) -> str:
        return "quilt" if instance.startswith("quilt") else super().instance_class(instance)  # tabs included

    def instruction(self) -> str:
        return "fold the quilt in half"

    def goal_nouns(self) -> list[str]:
        return ["quilt"]

    def place(self, sim: SimHandle, rng: np.random.Generator, region: tuple[tuple[float, float], ...]) -> None:
        centre = np.array([rng.uniform(*region[0]), rng.uniform(*region[1])])
        place_quilt(sim, centre, rng.uniform(-YAW, YAW))
        colour = self.pick_colours(rng, 1)[0]
        sim.model.flex_rgba[flex_id(sim), :3] = self.palette[colour]
        self.episode = {"colour": colour}


@register_task("quilt_folding")
class QuiltFolding(QuiltTask):
    bimanual = True
    tier = "Collaboration"
    paper_keyframes = 5

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        self.place(sim, rng, QUILT_REGION)

    def evaluate_success(self, sim: SimHandle) -> bool:
        return corner_folded(sim, "left") and corner_folded(sim, "right")

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {arm: [f"quilt_tab_{side}"] for arm, side in tab_roles(sim).items()}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        plan = {arm: fold_keyframes(sim, side) for arm, side in tab_roles(sim).items()}
        return [{"left": a, "right": b} for a, b in zip(plan["left"], plan["right"], strict=True)]


def tab_roles(sim: SimHandle) -> dict[str, str]:
    """Arm -> the tab it takes: each the one on its side (a left-right exchange puts the left tab on the right)."""
    arms = arms_by_side(sim.body_pos("quilt_tab_left")[1], sim.body_pos("quilt_tab_right")[1])
    return dict(zip(arms, ("left", "right"), strict=True))
