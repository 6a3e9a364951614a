"""The demos' roles (``--roles true``): per episode, which arm leads and which follows, and the assigner fitted on
them (``methods/role_assigner.py``).

An arm's hold sequence lists, keyframe by keyframe from the second, whether it repeats its previous action (it
waits while the other acts). The arm whose sequence starts moving earlier (lexicographically smaller, moving
before holding) leads; identical sequences (both arms act together) give the lead to the first arm in
``ARM_ORDER``, so a symmetric task's roles are its arms' order.
"""

from __future__ import annotations

import numpy as np

from bimanualshift.methods.role_assigner import RoleAssigner, role_features
from bimanualshift.perception.arm_samples import ArmSamples
from bimanualshift.training.configs import ARM_ORDER


def arm_indices(samples: ArmSamples) -> np.ndarray:
    return np.array([ARM_ORDER.index(a) if a in ARM_ORDER else 0 for a in samples.arm])


def demo_roles(samples: ArmSamples, holds: np.ndarray) -> np.ndarray:
    """(N,) int: each sample's role in its episode (0 leads, 1 follows) from the hold labels ``holds`` (N,)."""
    arm_index = arm_indices(samples)
    roles = arm_index.copy()
    for e in np.unique(samples.episode):
        rows = np.flatnonzero(samples.episode == e)
        arms = sorted({int(arm_index[i]) for i in rows})
        if len(arms) != 2:
            continue
        sequences = {a: tuple(int(holds[i] > 0.5) for i in sorted((i for i in rows if arm_index[i] == a and
                                                                   samples.keyframe[i] > 0),
                                                                  key=lambda i: samples.keyframe[i]))
                     for a in arms}
        leader = min(arms, key=lambda a: (sequences[a], a))
        roles[rows] = [0 if arm_index[i] == leader else 1 for i in rows]
    return roles


def first_keyframe_rows(samples: ArmSamples) -> np.ndarray:
    """Indices of every episode's keyframe-0 samples (both arms), in sample order."""
    return np.flatnonzero(np.asarray(samples.keyframe) == 0)


def sample_role_features(samples: ArmSamples, rows: np.ndarray) -> np.ndarray:
    goal = samples.goal[rows] if samples.goal is not None else np.zeros((len(rows), 0))
    return role_features(goal, samples.proprio[rows], samples.other_proprio[rows], arm_indices(samples)[rows])


def fit_role_assigner(samples: ArmSamples, holds: np.ndarray) -> RoleAssigner:
    """The assigner fitted on the demos' first keyframes, labelled by ``demo_roles``."""
    rows = first_keyframe_rows(samples)
    return RoleAssigner.fit(sample_role_features(samples, rows), demo_roles(samples, holds)[rows],
                            arm_indices(samples)[rows])


def assigned_roles(assigner: RoleAssigner, samples: ArmSamples) -> np.ndarray:
    """(N,) each sample's role as the assigner decides it at its episode's first keyframe (what inference does:
    validation demos are judged as a rollout would be, not by their own labels)."""
    roles = arm_indices(samples).copy()
    first = first_keyframe_rows(samples)
    for e in np.unique(samples.episode):
        at_start = [i for i in first if samples.episode[i] == e]
        decided = assigner.assign(sample_role_features(samples, np.array(at_start)))
        by_arm = {samples.arm[i]: int(r) for i, r in zip(at_start, decided)}
        for i in np.flatnonzero(samples.episode == e):
            roles[i] = by_arm.get(samples.arm[i], roles[i])
    return roles
