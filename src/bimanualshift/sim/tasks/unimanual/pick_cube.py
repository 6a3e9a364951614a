"""Single arm: pick up the cube of the named colour among one to three cubes."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bimanualshift.geometry.frames import canonical_quat
from bimanualshift.sim.layout import TABLE_TOP_Z
from bimanualshift.sim.props.blocks import CUBE_HALF, cube_xml
from bimanualshift.sim.props.placement import sample_separated
from bimanualshift.sim.task import DOWN_QUAT, ArmAction, Keyframe, SimHandle, Task, register_task

CUBES = ("cube_0", "cube_1", "cube_2")
REGION = ((-0.10, 0.15), (-0.30, 0.30))
LIFTED_BY = 0.05  # metres above the table that count as picked up


@register_task("pick_cube")
class PickCube(Task):
    bimanual = False
    other_robots = ("ur5e",)  # its expert also runs on the UR5e twin (results/experts_ur5e.json)

    def scene_xml(self) -> str:
        return "".join(cube_xml(c, sphere=self.perturbations.unseen_shapes) for c in CUBES)

    def initialize_episode(self, sim: SimHandle, rng: np.random.Generator) -> None:
        n = int(rng.integers(1, len(CUBES) + 1))
        colours = self.pick_colours(rng, len(CUBES))
        xy = sample_separated(rng, [REGION] * n, min_distance=0.12)
        yaws = rng.uniform(-np.pi / 4, np.pi / 4, size=len(CUBES))
        for i, name in enumerate(CUBES):
            p = np.r_[xy[i], TABLE_TOP_Z + CUBE_HALF] if i < n else np.array([1.5, 0.2 * i, 0.1])
            sim.set_free_pose(f"{name}_joint", p, Rotation.from_euler("z", yaws[i]).as_quat())
            sim.set_rgb(f"{name}_geom", self.palette[colours[i]])
        self.episode = {"colours": colours, "count": n, "target": int(rng.integers(n))}

    def instruction(self) -> str:
        return f"pick up the {self.episode['colours'][self.episode['target']]} cube"

    def evaluate_success(self, sim: SimHandle) -> bool:
        z = sim.body_pos(CUBES[self.episode["target"]])[2]
        return bool(z > TABLE_TOP_Z + CUBE_HALF + LIFTED_BY)

    def expert_keyframes(self, sim: SimHandle) -> list[Keyframe]:
        cube = CUBES[self.episode["target"]]
        pos = sim.body_pos(cube)
        yaw = Rotation.from_matrix(sim.data.xmat[sim.body_id(cube)].reshape(3, 3)).as_euler("xyz")[2]
        yaw = (yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4  # a cube looks the same every 90 degrees
        quat = canonical_quat((Rotation.from_euler("z", yaw) * Rotation.from_quat(DOWN_QUAT)).as_quat())
        grasp = pos + [0, 0, 0.0]
        return [
            {"right": ArmAction(grasp + [0, 0, 0.10], quat, 1.0, 1.0)},
            {"right": ArmAction(grasp, quat, 1.0, 0.0)},
            {"right": ArmAction(grasp, quat, 0.0, 0.0)},
            {"right": ArmAction(grasp + [0, 0, 0.15], quat, 0.0, 1.0)},
        ]
