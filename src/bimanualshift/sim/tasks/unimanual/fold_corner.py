"""Single arm, on the UR5e twin: take the quilt's near corner by its tab and lay it on the far corner on the same
side (fold a cloth corner), the skill of each arm of Quilt Folding. The quilt lies 27-33 cm to either side of the
arm, as it lies from each arm's base in that task, and the arm takes the corner nearer its own side. Success: that
corner within 5 cm of the far corner, lying on the quilt."""

from __future__ import annotations

import numpy as np

from bimanualshift.sim.layout import skill_side
from bimanualshift.sim.task import Keyframe, SimHandle, register_task
from bimanualshift.sim.tasks.realworld.quilt_folding import QUILT_REGION, QuiltTask, corner_folded, fold_keyframes

QUILT_Y = (0.27, 0.33)  # |y| of the quilt's middle from the arm's base


@register_task("fold_corner")
class FoldCorner(QuiltTask):
    bimanual = False

    def instruction(self) -> str:
        return "fold the corner of the quilt over"

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        side = skill_side(rng)
        region = (QUILT_REGION[0], QUILT_Y if side > 0 else (-QUILT_Y[1], -QUILT_Y[0]))
        self.place(sim, rng, region)
        # the quilt to the arm's left (+y) puts its right corner nearest the arm, as the right arm's in the task
        self.episode["corner"] = "right" if side > 0 else "left"

    def evaluate_success(self, sim: SimHandle) -> bool:
        return corner_folded(sim, self.episode["corner"])

    def arm_goals(self, sim: SimHandle) -> dict[str, list[str]]:
        return {"right": [f"quilt_tab_{self.episode['corner']}"]}

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        return [{"right": a} for a in fold_keyframes(sim, self.episode["corner"])]
