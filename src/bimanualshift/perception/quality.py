"""How well the projection separates the arms, measured in voxels against the simulator's ground truth.

For each arm and keyframe: *kept* = the fraction of the voxels holding that arm or a goal object that the
arm's projected observation still holds (recall), *removed* = the fraction of the other arm's voxels it no
longer holds. Voxels are 2 cm cells of the table-top workspace; a voxel belongs to an instance when any of
its back-projected pixels does.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bimanualshift.core.goal_nouns import split_prompt
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.observation import world_point_cloud
from bimanualshift.perception.projection import ArmProjection

# 2 cm cells over the table-top workspace: what the quality figures and the projection figure count in
WORLD_GRID = VoxelGrid((-0.55, -0.6, 0.78, 0.45, 0.6, 1.4), 56)


def voxel_set(points: np.ndarray, grid: VoxelGrid) -> set[int]:
    inside = np.all((points >= grid.lower) & (points < grid.upper), axis=-1)
    return set(np.ravel_multi_index(grid.point_to_index(points[inside]).T, (grid.size,) * 3).tolist())


@dataclass
class QualityTally:
    """Sums over keyframes, per arm, of wanted / kept-wanted / other / kept-other voxel counts."""

    counts: dict[str, np.ndarray] = field(default_factory=dict)

    def add(self, arm: str, wanted: int, kept: int, other: int, leaked: int) -> None:
        self.counts.setdefault(arm, np.zeros(4, np.int64))
        self.counts[arm] += (wanted, kept, other, leaked)

    def rates(self, arm: str) -> tuple[float, float]:
        wanted, kept, other, leaked = self.counts[arm]
        return kept / max(wanted, 1), 1.0 - leaked / max(other, 1)


def measure_keyframe(obs: KeyframeObservation, projection: ArmProjection, tally: QualityTally,
                     goal_instances: list[int], grid: VoxelGrid = WORLD_GRID) -> None:
    """Add one keyframe's counts; ``goal_instances`` are the instance ids of the goal objects."""
    points, _ = world_point_cloud(obs)
    valid = np.isfinite(obs.depth) & (obs.depth > 0)
    names = obs.scene.instance_names
    masks = projection.masks_2d(obs)
    for arm in obs.scene.arm_names:
        other = next(a for a in obs.scene.arm_names if a != arm)
        own = obs.instance == names.index(f"arm_{arm}")
        theirs = obs.instance == names.index(f"arm_{other}")
        goal = np.isin(obs.instance, goal_instances)
        wanted = voxel_set(points[valid & (own | goal)], grid)
        kept = voxel_set(points[valid & masks[arm]], grid)
        other_voxels = voxel_set(points[valid & theirs], grid) - wanted  # shared cells are not the other arm's
        tally.add(arm, len(wanted), len(wanted & kept), len(other_voxels), len(other_voxels & kept))



def goal_instances(instance_class: np.ndarray, class_names: list[str], goal_nouns: list[str],
                   instance_names: list[str], colours: dict[str, list[str]]) -> list[int]:
    """The instance ids the goal prompts name, read as the simulator segmenter reads them.

    "navy button" names the buttons painted navy; a plain noun names its whole class. A prompt that names
    no instance raises: the ground truth would silently leave that goal out of every figure.
    """
    found: set[int] = set()
    for prompt in goal_nouns:
        colour, noun = (None, prompt) if prompt in class_names else split_prompt(prompt)
        named = [i for i, c in enumerate(instance_class) if class_names[int(c)] == noun
                 and (colour is None or colour in colours.get(instance_names[i], []))]
        if not named:
            raise ValueError(f"goal prompt {prompt!r} names no instance of this scene (classes: {class_names}); "
                             "give the task a goal noun that is one of its classes")
        found.update(named)
    return sorted(found)


def projection_quality(task: str, seeds: list[int], segmenters: list[str], image_size: int | None = None,
                       progress: bool = True) -> list[dict]:
    """Per segmenter and arm, kept / removed over every keyframe of the expert's episodes on ``seeds``."""
    from tqdm import tqdm

    from bimanualshift.data.frames import scene_of_env
    from bimanualshift.perception.segmenters import make_segmenter
    from bimanualshift.sim.env import ManipulationEnv

    env = ManipulationEnv(task, image_size=image_size)
    projections = {name: ArmProjection(make_segmenter(name, seed=0)) for name in segmenters}
    tallies = {name: QualityTally() for name in segmenters}
    keyframes = 0
    for seed in tqdm(seeds, desc=f"projection {task}", unit="ep", disable=not progress):
        obs, _ = env.reset(seed=seed)
        scene = scene_of_env(env)
        goals = goal_instances(env.instances.instance_class, env.instances.classes, scene.goal_nouns,
                               scene.instance_names, scene.instance_colours)
        for step, keyframe in enumerate([None, *env.expert_keyframes()]):
            if keyframe is not None:
                obs, *_ = env.step(env.action_from_keyframe(keyframe))
            frame = KeyframeObservation.from_env(obs, scene)
            frame.keyframe_index = step
            for name, projection in projections.items():
                measure_keyframe(frame, projection, tallies[name], goals)
            keyframes += 1
    env.close()
    rows = []
    for name, tally in tallies.items():
        for arm in env.arm_names:
            kept, removed = tally.rates(arm)
            wanted, _, other, _ = tally.counts[arm].tolist()
            rows.append({"task": task, "segmenter": name, "arm": arm, "kept": round(kept, 4),
                         "removed": round(removed, 4), "episodes": len(seeds), "keyframes": keyframes,
                         "wanted_voxels": wanted, "other_arm_voxels": other,
                         "diagnostics": vars(projections[name].diagnostics).copy()})
    return rows


def projection_quality_job(job: tuple[str, list[int], list[str], int]) -> list[dict]:
    """``projection_quality`` of one (task, seeds, segmenters, image size) in a worker process."""
    return projection_quality(*job, progress=False)
