"""Can an arm tell its role from what the Manager reads at the first keyframe? (writes results/role_cues.json)

    .venv/bin/python benchmarks/investigations/role_cues.py --task take_tray_out_of_oven --scenes 300

In take tray out of oven the arm that opens the door and the arm that takes the tray swap with the oven's turn
(``Task.roles``), and both arms see the same goal objects. For each training scene's first keyframe, both arms:
the role label from the task, and the inputs the Manager reads besides the prior's features and the instruction
(the goal geometry, ``perception/goal_geometry.py``, and both arms' proprioception, in the arm's frame). A logistic
regression, cross-validated over scenes, measures how well those inputs give the role; the same with the goal
points' horizontal orientation added (the principal axis as cos 2θ, sin 2θ, scaled by its anisotropy) measures
whether that cue is the missing one. Nothing is trained beyond the probes; nothing is rolled out.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from tqdm import tqdm

from bimanualshift.data.frames import KeyframeObservation, scene_of_env
from bimanualshift.data.seeds import split_seeds
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.methods.instruction_chooser import InstructionChooser
from bimanualshift.perception.goal_geometry import goal_world_points
from bimanualshift.perception.observation import DEFAULT_ARM_BOUNDS, ArmObservationBuilder, arm_frames
from bimanualshift.perception.projection import ArmProjection
from bimanualshift.perception.segmenters.simulator import SimulatorSegmenter
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.utils.pipes import quiet_on_closed_pipe

FOLDS = 5


def horizontal_orientation(points_arm: np.ndarray) -> np.ndarray:
    """(3,) the horizontal principal axis of the points as (cos 2θ, sin 2θ) times the anisotropy
    (λ1 - λ2) / (λ1 + λ2), and the anisotropy itself: a sign-free axis, zero for a round footprint."""
    if len(points_arm) < 3:
        return np.zeros(3)
    xy = points_arm[:, :2] - points_arm[:, :2].mean(0)
    cxx, cyy, cxy = float(np.mean(xy[:, 0] ** 2)), float(np.mean(xy[:, 1] ** 2)), float(np.mean(xy[:, 0] * xy[:, 1]))
    spread = cxx + cyy
    if spread <= 0:
        return np.zeros(3)
    anisotropy = float(np.hypot(cxx - cyy, 2 * cxy)) / spread
    angle = np.arctan2(2 * cxy, cxx - cyy)  # 2θ
    return np.array([np.cos(angle) * anisotropy, np.sin(angle) * anisotropy, anisotropy])


def cross_validated_accuracy(x: np.ndarray, y: np.ndarray, scene: np.ndarray, arm: np.ndarray,
                             train_scenes: int | None = None) -> float:
    """Held-out accuracy over ``FOLDS`` folds of scenes, one probe per arm (the Manager tells the arms apart by
    the other arm's side, and the role is the arm's side crossed with the scene). The probe is the library's
    instruction chooser (a standardised, L2-regularised logistic regression) with the roles as its classes."""
    folds = scene % FOLDS
    labels = np.where(y > 0.5, "tray", "door")
    correct = 0
    for f, a in ((f, a) for f in range(FOLDS) for a in np.unique(arm)):
        train, test = (folds != f) & (arm == a), (folds == f) & (arm == a)
        if train_scenes is not None:  # the first scenes outside the fold, as a demo set of that size
            train &= np.isin(scene, np.unique(scene[folds != f])[:train_scenes])
        probe = InstructionChooser.fit(x[train], list(labels[train]))
        correct += int(np.sum(np.asarray(probe.choose(x[test])) == labels[test]))
    return correct / len(y)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="take_tray_out_of_oven")
    parser.add_argument("--scenes", type=int, default=300, help="training seeds (their first keyframe only)")
    parser.add_argument("--demos", type=int, default=30, help="also fit each probe on this many scenes alone")
    parser.add_argument("--out", default="results/role_cues.json")
    args = parser.parse_args()
    started = time.time()
    env = ManipulationEnv(args.task)
    if not hasattr(env.task, "roles"):
        sys.exit(f"error: task {args.task} declares no arm roles (Task.roles)")
    projection = ArmProjection(SimulatorSegmenter())
    builder = ArmObservationBuilder(VoxelGrid(DEFAULT_ARM_BOUNDS, 16), projection, voxels=False, points=1)
    seeds = split_seeds("train", args.scenes)
    manager, orientation, labels, scene_index, arm_index = [], [], [], [], []
    for s, seed in enumerate(tqdm(seeds, desc=args.task, unit="scene")):
        raw, _ = env.reset(seed=seed)
        obs = KeyframeObservation.from_env(raw, scene_of_env(env))
        per_arm = builder.build(obs)
        _, goal_mask = projection.project(obs)
        goal_points = goal_world_points(obs, goal_mask)
        door_arm, _ = env.task.roles(env.sim)
        for i, (arm, frame) in enumerate(arm_frames(obs).items()):
            a = per_arm[arm]
            manager.append(np.r_[a.goal, a.proprio, a.other_proprio])
            orientation.append(horizontal_orientation(frame.points_to_arm(goal_points.astype(np.float64))))
            labels.append(float(arm != door_arm))  # 1: this arm takes the tray
            scene_index.append(s)
            arm_index.append(i)
    x_manager, x_orientation = np.asarray(manager), np.asarray(orientation)
    y, scene = np.asarray(labels), np.asarray(scene_index)
    rows = []
    for name, x in (("goal geometry + both proprio (what the Manager reads)", x_manager),
                    ("the same + horizontal orientation", np.c_[x_manager, x_orientation]),
                    ("horizontal orientation alone", x_orientation)):
        accuracy = cross_validated_accuracy(x, y, scene, np.asarray(arm_index))
        few = cross_validated_accuracy(x, y, scene, np.asarray(arm_index), args.demos)
        rows.append({"inputs": name, "features": int(x.shape[1]), "arms": len(y),
                     "role_accuracy": round(accuracy, 3), f"role_accuracy_{args.demos}_scenes": round(few, 3)})
        print(f"{name}: {x.shape[1]} numbers, held-out role accuracy {accuracy:.1%} ({few:.1%} when fitted on "
              f"{args.demos} scenes)")
    majority = round(float(max(y.mean(), 1 - y.mean())), 3)
    rows.append({"inputs": "majority role", "features": 0, "arms": len(y), "role_accuracy": majority,
                 f"role_accuracy_{args.demos}_scenes": majority})
    command = invoked_command()
    write_result(args.out, command, {"train": seeds}, started, rows,
                 notes=f"{args.task}, first keyframe of each training scene, both arms; role: 1 for the arm the "
                       f"task gives the tray; accuracy of a logistic regression per arm held out over "
                       f"{FOLDS} folds of scenes", task=args.task)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
