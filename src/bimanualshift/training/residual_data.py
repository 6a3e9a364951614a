"""The residual's training samples: per (keyframe, arm) the Manager's input row as its config reads it and the
targets (translation, rotation, gripper, hold; for the action-space residual, the prior's own lattice cell and
rotation bins), from the frozen prior's outputs on the demos, optionally through augmented copies of each scene
and with the retrieved temporal reference of the episode.

The frozen prior's outputs do not change during training, so they are computed once per keyframe and arm (and
augmented copy) and cached: each training step then costs only the Manager, Z and G.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from bimanualshift.encoders.text import TextEncoder
from bimanualshift.geometry.frames import grasp_twin_mean, nearest_grasp_twin, quat_to_euler_bins, rotation_difference
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.memory.bank import MemoryBank, MemoryEntry
from bimanualshift.memory.reference import REFERENCE_DIM, ProgressAlignment, episode_key, reference_vector
from bimanualshift.methods.prior_step import FrozenPriorStep
from bimanualshift.methods.role_assigner import RoleAssigner
from bimanualshift.perception.arm_samples import ArmSamples, build_arm_samples
from bimanualshift.priors.base import PriorOutput, UnimanualPrior
from bimanualshift.residual.heading_anchor import anchored_base, fit_anchors
from bimanualshift.residual.manager import ResidualConfig, action_lattice, manager_input_rows, phase_one_hot
from bimanualshift.training.augment import (
    Se3Augmentation,
    sample_motion,
    transform_goal_geometry,
    transform_points,
    transform_poses,
    transform_quats,
    transform_scene,
)
from bimanualshift.training.prior_instruction import sample_features
from bimanualshift.training.roles import arm_indices, assigned_roles, demo_roles


@dataclass
class ResidualData:
    inputs: torch.Tensor  # (N, manager input width)
    translation: torch.Tensor  # (N, 3) target residual: expert - prior, arm frame
    rotation: torch.Tensor  # (N, 3) axis-angle r with exp(r) * R_prior = R_expert
    memory: MemoryBank | None = None  # the bank the references came from (built here with ``build_memory``)
    gripper: torch.Tensor | None = None  # (N,) the expert's gripper: 1 open, 0 closed
    hold: torch.Tensor | None = None  # (N,) 1 where the expert keeps this arm's previous action (``hold_labels``)
    # an action-space residual's: the prior's log-probabilities on the lattice around its proposal (N, W^3) and of
    # its rotation bins (N, 3, R); the lattice cell nearest the expert's position (N,) and the expert's bins (N, 3)
    prior_translation: torch.Tensor | None = None
    prior_rotation: torch.Tensor | None = None
    target_cell: torch.Tensor | None = None
    target_bins: torch.Tensor | None = None
    # "slot_twin"'s references the rotation targets were taken towards (``ResidualConfig.twin_references``)
    twin_references: tuple[float, ...] = ()
    # the heading anchor's per-slot frame and grasp the base orientations were set to
    # (``ResidualConfig.heading_anchors``)
    heading_anchors: tuple[float, ...] = ()

    def __len__(self) -> int:
        return len(self.inputs)

    def rows(self, index: torch.Tensor) -> ResidualData:
        """The samples at ``index`` (a batch)."""
        pick = {f: (None if getattr(self, f) is None else getattr(self, f)[index]) for f in TARGET_FIELDS}
        return ResidualData(self.inputs[index], self.translation[index], self.rotation[index], **pick)


TARGET_FIELDS = ("gripper", "hold", "prior_translation", "prior_rotation", "target_cell", "target_bins")
# An arm holds at a keyframe when its target repeats its previous keyframe's: the same gripper state, within
# these distances (the experts repeat an idle arm's action exactly; a moving arm's keyframes are centimetres apart).
HOLD_TOLERANCE_M = 0.005
HOLD_TOLERANCE_RAD = 0.05


def hold_labels(samples: ArmSamples) -> np.ndarray:
    """(N,) float: 1 where a sample's action repeats the same arm's action at the previous keyframe of its
    episode (the arm waits while the other acts), else 0; an episode's first keyframe is never a hold."""
    where = {(int(e), a, int(k)): i for i, (e, a, k) in enumerate(zip(samples.episode, samples.arm, samples.keyframe))}
    out = np.zeros(len(samples), np.float32)
    for i, (e, arm, k) in enumerate(zip(samples.episode, samples.arm, samples.keyframe)):
        j = where.get((int(e), arm, int(k) - 1))
        if j is None:
            continue
        rows = [np.r_[samples.action_pos[m], samples.action_quat[m], samples.gripper_open[m]] for m in (i, j)]
        out[i] = float(repeats(*rows))
    return out


def repeats(action: np.ndarray, previous: np.ndarray) -> bool:
    """Whether an action (position, quaternion, gripper, ...) repeats the arm's previous one in the same frame:
    the same gripper state, within ``HOLD_TOLERANCE_M`` and ``HOLD_TOLERANCE_RAD`` (a hold)."""
    near = np.linalg.norm(action[:3] - previous[:3]) < HOLD_TOLERANCE_M
    turned = np.linalg.norm(rotation_difference(action[3:7], previous[3:7]))
    return bool(near and turned < HOLD_TOLERANCE_RAD and (action[7] > 0.5) == (previous[7] > 0.5))


def rotation_target(config: ResidualConfig, quat_target: np.ndarray, quat_base: np.ndarray,
                    reference: np.ndarray | None = None) -> np.ndarray:
    """The rotation residual's target (axis-angle r with exp(r) * R_prior = R_target) under the config's
    ``rotation_target``: towards the expert's orientation, its grasp twin nearer the prior's proposal
    ("nearest_twin"), or its twin nearer ``reference``, the demos' mean grasp at this arm and keyframe slot
    ("slot_twin": ``ResidualConfig.twin_reference``)."""
    if config.rotation_target == "nearest_twin":
        quat_target = nearest_grasp_twin(quat_target, quat_base)
    elif config.rotation_target == "slot_twin":
        if reference is None:
            raise ValueError("rotation_target 'slot_twin' needs the arm and keyframe slot's twin reference")
        quat_target = nearest_grasp_twin(quat_target, reference)
    return rotation_difference(quat_target, quat_base)


def slot_twin_references(config: ResidualConfig, arm_index: np.ndarray, keyframe: np.ndarray,
                         quats: np.ndarray) -> tuple[float, ...]:
    """``ResidualConfig.twin_references`` from training samples (arm-frame expert quaternions): per arm and
    keyframe slot of the phase one-hot, the demos' mean grasp modulo the half turn (``grasp_twin_mean``), each
    slot's taken as the twin nearer the slot before it so that the arm's wrist does not spin half a turn between
    keyframes. A slot no demo reaches repeats the slot before it.

    Why: the demos wrap wrist yaw into a half turn, so a grasp near the wrap's edge (sweep's dustpan handle) comes
    as either twin at random by scene, and the residual, asked to turn one way in half the scenes and the other
    way in the rest, learns the average; every target taken towards one mean asks the same turn."""
    slot = config.phase_slot(keyframe)
    out = []
    for arm in range(config.num_arms):
        previous = None
        for s in range(config.slots_per_arm):
            chosen = quats[(arm_index == arm) & (slot == s)]
            if len(chosen):
                mean = grasp_twin_mean(chosen)
                previous = mean if previous is None else nearest_grasp_twin(mean, previous)
            out.append(np.array([0.0, 0.0, 0.0, 1.0]) if previous is None else previous)
    return tuple(float(x) for x in np.concatenate(out))


def residual_data(config: ResidualConfig, paths: list[Path], prior_step: FrozenPriorStep, text_encoder: TextEncoder,
                  desc: str, augmentation: Se3Augmentation | None = None, augment_copies: int = 0, seed: int = 0,
                  memory: MemoryBank | None = None, own_memory: bool = False, build_memory: float | None = None,
                  task: str = "", earlier_memory: MemoryBank | None = None,
                  samples: ArmSamples | None = None, role_assigner: RoleAssigner | None = None) -> ResidualData:
    """Manager inputs (as ``config`` reads them) and residual targets for every (keyframe, arm), from the frozen
    prior's outputs.

    With ``augment_copies`` > 0, each sample is also seen through that many random rigid motions of its scene
    (``augmentation``: a yaw about the grid's vertical axis and a horizontal shift, the paper's SE(3)
    augmentation); the targets, both arms' poses, the goal geometry and the retrieved reference move with it, and
    the frozen prior is run on each moved copy once: a fixed pool of augmented samples the prior's cache allows.

    With a ``memory`` bank, each sample also gets the retrieved temporal reference of its episode; with
    ``own_memory`` the bank's first entries are these very episodes (in order) and an episode never retrieves
    itself. ``build_memory`` (a confidence threshold) builds that bank from these episodes in the same pass,
    followed by the entries of ``earlier_memory`` (an earlier task's bank) when given. ``samples``, when given,
    are ``paths``' samples already built (``build_arm_samples``), so the demos are not voxelised twice.

    With ``config.role_phase`` each row's role is the demos' own (``training/roles.py``), or with a
    ``role_assigner`` the one it decides at the episode's first keyframe (validation: as a rollout would).
    """
    if augment_copies and augmentation is None:
        raise ValueError("augment_copies > 0 needs an augmentation (Se3Augmentation)")
    if samples is None:
        samples = build_arm_samples(paths, prior_step.builder, prior_step.prior.config.max_keyframes, desc=desc)
    grid = prior_step.builder.grid
    n = len(samples)
    arm_index = torch.as_tensor(arm_indices(samples))
    text = torch.as_tensor(text_encoder.encode(samples.instructions))  # the residual's (Manager, memory key)
    # the prior's own encoder, and the instruction it is asked (``prior_step.prior_instruction``, or per arm its
    # chooser's pick from the unmoved sample: a role does not change with a rigid motion of the scene)
    chooser_input = sample_features(samples) if prior_step.instruction_chooser is not None else None
    prior_text = torch.as_tensor(prior_step.text_encoder.encode(prior_step.prior_texts(samples.instructions,
                                                                                       chooser_input)))
    generator = torch.Generator().manual_seed(seed)
    gripper = torch.as_tensor(samples.gripper_open, dtype=torch.float32)
    hold = torch.as_tensor(hold_labels(samples))
    role = None
    if config.role_phase:
        role = torch.as_tensor(assigned_roles(role_assigner, samples) if role_assigner is not None
                               else demo_roles(samples, hold.numpy()))
    clouds = prior_step.prior.observation == "points"
    scene = torch.as_tensor(samples.points if clouds else samples.voxels)
    target_pos, target_quat = torch.as_tensor(samples.action_pos), torch.as_tensor(samples.action_quat)
    two_arms = bool(samples.other_proprio.any())
    twin_reference = None  # (N, 4) with "slot_twin": each sample's arm and keyframe slot's mean grasp
    if config.rotation_target == "slot_twin":
        if not config.twin_references:  # training data: the references come from these very demos
            config = replace(config, twin_references=slot_twin_references(
                config, arm_index.numpy(), samples.keyframe, samples.action_quat))
        slots = config.phase_slot(samples.keyframe)
        twin_reference = torch.as_tensor(np.stack([config.twin_reference(int(a), int(s))
                                                   for a, s in zip(arm_index, slots)]))
    phase = None  # (N, phase_dim) with the heading anchor: each row's (arm or role, keyframe) slot
    if config.heading_anchor:
        phase = phase_one_hot(config, torch.as_tensor(samples.keyframe), arm_index, role)
    parts = []
    for copy in range(1 + augment_copies):
        if copy == 0:
            yaw, shift = torch.zeros(n), torch.zeros(n, 3)
        else:
            yaw, shift = sample_motion(augmentation, generator, target_pos[:, None], grid)
        proprio = transform_poses(torch.as_tensor(samples.proprio), grid, yaw, shift)
        other = torch.as_tensor(samples.other_proprio)
        other = transform_poses(other, grid, yaw, shift) if two_arms else other
        moved_pos = transform_points(target_pos, grid, yaw, shift)
        quat = transform_quats(target_quat, yaw).numpy()
        features, base, proposal, action_parts = [], [], [], []
        with torch.no_grad():
            for start in range(0, n, 32):
                sl = slice(start, start + 32)
                moved = transform_scene(scene[sl].float(), grid, yaw[sl], shift[sl]) if copy else scene[sl].float()
                batch = (moved, proprio[sl], prior_text[sl])
                out = prior_step.prior.predict(*batch)
                features.append(out.features)
                base.append(out.base_action())
                if config.proposal_dim:
                    proposal.append(prior_step.prior.proposal_features(*batch, out))
                if config.action_space:
                    action_parts.append(action_space_targets(prior_step.prior, out, config, moved_pos[sl], quat[sl]))
        features_t, base_t = torch.cat(features), torch.cat(base)
        moved_goal = (transform_goal_geometry(torch.as_tensor(samples.goal), grid, yaw, shift) if config.goal_dim
                      else None)
        if phase is not None:
            if not config.heading_anchors:  # training data: the anchors come from these very demos and prior
                config = replace(config, heading_anchors=fit_anchors(
                    phase.argmax(-1).numpy(), config.phase_dim, samples.goal, samples.action_quat,
                    base_t[:, 3:7].numpy())[0])
            base_t = anchored_base(config.heading_anchors, phase, moved_goal, base_t, yaw)
        proposal_t = torch.cat(proposal) if proposal else None
        if copy == 0:
            first_features = features_t
            if build_memory is not None:
                memory, own_memory = episode_memory(samples, first_features, text, build_memory, task), True
                if earlier_memory is not None:
                    memory.extend(earlier_memory)
        reference = None
        if memory is not None:
            reference = retrieved_references(samples, first_features, text, base_t, memory, own_memory,
                                             (grid, yaw, shift))
        goal = moved_goal
        # the episode's first keyframe's goal, seen through this row's motion (the whole scene moves as one)
        start_goal = (transform_goal_geometry(torch.as_tensor(samples.goal[first_rows(samples)]), grid, yaw, shift)
                      if config.start_goal_dim else None)
        inputs = manager_input_rows(config, features_t, proprio, other, text, base_t, arm_index,
                                    torch.as_tensor(samples.keyframe), reference, goal, proposal_t, start_goal, role)
        translation = moved_pos - base_t[:, :3]
        base_quat = base_t[:, 3:7].numpy()
        # a reference grasp turns with the scene, as the expert's does
        reference_quat = (transform_quats(twin_reference, yaw).numpy() if twin_reference is not None
                          else [None] * n)
        rotation = torch.as_tensor(np.stack([rotation_target(config, t, b, r)
                                             for t, b, r in zip(quat, base_quat, reference_quat)]),
                                   dtype=torch.float32)
        action_targets = {name: torch.cat([part[name] for part in action_parts]) for name in ACTION_SPACE_FIELDS
                          } if action_parts else {}
        parts.append(ResidualData(inputs, translation, rotation, gripper=gripper, hold=hold, **action_targets))
    fields = ("inputs", "translation", "rotation", *TARGET_FIELDS)
    merged = {f: (None if getattr(parts[0], f) is None else torch.cat([getattr(p, f) for p in parts]))
              for f in fields}
    return ResidualData(**merged, memory=memory, twin_references=config.twin_references,
                        heading_anchors=config.heading_anchors)


def first_rows(samples: ArmSamples) -> np.ndarray:
    """(N,) per sample, the index of its episode's first keyframe's sample of the same arm."""
    first = {(int(e), a): i for i, (e, a, k) in enumerate(zip(samples.episode, samples.arm, samples.keyframe))
             if k == 0}
    missing = {(int(e), a) for e, a in zip(samples.episode, samples.arm)} - set(first)
    if missing:
        raise ValueError(f"episode {sorted(missing)[0][0]} has no keyframe 0 for arm {sorted(missing)[0][1]!r}: the "
                         "first keyframe's goal cannot be read (are the demos cut?)")
    return np.array([first[(int(e), a)] for e, a in zip(samples.episode, samples.arm)])


ACTION_SPACE_FIELDS = ("prior_translation", "prior_rotation", "target_cell", "target_bins")


@torch.no_grad()
def action_space_targets(prior: UnimanualPrior, out: PriorOutput, config: ResidualConfig, position: torch.Tensor,
                         quats: np.ndarray) -> dict[str, torch.Tensor]:
    """An action-space residual's targets for a batch of the prior's outputs ``out``: the prior's
    log-probabilities on the lattice around its proposal (B, W^3) and of its rotation bins (B, 3, R), the lattice
    cell nearest each target ``position`` (B, 3, arm frame) and the target quaternions' (B, 4) rotation bins.
    The demos (``residual_data``) and the corrector's actions (refinement, Eq. 10) both go through here."""
    cells = out.position[:, None] + action_lattice(config)[None]
    return {"prior_translation": prior.translation_scores(out, cells),
            "prior_rotation": F.log_softmax(out.logits["rotation"].float(), -1),
            "target_cell": (cells - position[:, None]).norm(dim=-1).argmin(-1),
            "target_bins": torch.as_tensor(np.stack([quat_to_euler_bins(q, prior.rotation_bin_degrees)
                                                     for q in quats]))}


def episode_memory(samples: ArmSamples, features: torch.Tensor, text: torch.Tensor, threshold: float,
                   task: str = "") -> MemoryBank:
    """A bank of the demos themselves (one entry per episode, in episode order): key from the instruction and
    the prior's features of both arms at keyframe 0, trajectory = every keyframe's arm-frame action per arm."""
    keys, trajectories, names = _episode_rows(samples, features, text)
    bank = MemoryBank(keys[0].shape[0], threshold)
    for e, (key, trajectory) in enumerate(zip(keys, trajectories)):
        bank.add(key, trajectory, MemoryEntry(task, names[e], "demo", e))
    return bank


def _episode_rows(samples: ArmSamples, features: torch.Tensor, text: torch.Tensor
                  ) -> tuple[list[np.ndarray], list[np.ndarray], list[str]]:
    keys, trajectories, names = [], [], []
    for e in np.unique(samples.episode):
        rows = np.flatnonzero(samples.episode == e)
        arms = list(dict.fromkeys(samples.arm[i] for i in rows))
        first = [features[next(i for i in rows if samples.keyframe[i] == 0 and samples.arm[i] == a)].numpy()
                 for a in arms]
        keys.append(episode_key(text[rows[0]].numpy(), first))
        steps = int(samples.keyframe[rows].max()) + 1
        trajectory = np.zeros((steps, len(arms), 8), np.float32)
        for i in rows:
            trajectory[samples.keyframe[i], arms.index(samples.arm[i])] = np.r_[
                samples.action_pos[i], samples.action_quat[i], samples.gripper_open[i]]
        trajectories.append(trajectory)
        names.append(samples.instructions[rows[0]])
    return keys, trajectories, names


Motion = tuple[VoxelGrid, torch.Tensor, torch.Tensor]  # (grid, yaw (N,), translation (N, 3)) of an augmented copy


def retrieved_references(samples: ArmSamples, first_features: torch.Tensor, text: torch.Tensor,
                         base: torch.Tensor, memory: MemoryBank, own_memory: bool, motion: Motion | None = None
                         ) -> torch.Tensor:
    """(N, REFERENCE_DIM): each sample's retrieved reference at its keyframe, for its arm; in an augmented copy
    (``motion``) the stored action moves with the scene, so it stays where the scene's objects are."""
    keys, _, _ = _episode_rows(samples, first_features, text)
    episodes = list(np.unique(samples.episode))
    found = [memory.search(key, exclude={e} if own_memory else set()) for e, key in enumerate(keys)]
    zero = np.zeros(8, np.float32)  # relative to a zero base: the stored position itself
    out = np.zeros((len(samples), REFERENCE_DIM), np.float32)
    retrieved = torch.zeros(len(samples), dtype=torch.bool)  # without a retrieval the row stays all zeros
    alignments = [ProgressAlignment(f.trajectory) if f is not None else None for f in found]
    # each arm's aligned step, in keyframe order within its episode (as the policy meets them at inference)
    for i in sorted(range(len(samples)), key=lambda i: (int(samples.episode[i]), int(samples.keyframe[i]))):
        e = episodes.index(samples.episode[i])
        arms = list(dict.fromkeys(samples.arm[j] for j in np.flatnonzero(samples.episode == samples.episode[i])))
        arm = arms.index(samples.arm[i])
        own = samples.proprio[i]
        step = alignments[e].step_of(arm, own[:3], float(own[7])) if alignments[e] is not None else 0
        out[i] = reference_vector(found[e], step, arm, zero)
        retrieved[i] = found[e] is not None
    stored = torch.as_tensor(out)
    if motion is not None:
        grid, yaw, shift = motion
        stored[:, :7] = torch.where(retrieved[:, None], transform_poses(stored[:, :7], grid, yaw, shift),
                                    stored[:, :7])
    stored[:, :3] -= torch.where(retrieved[:, None], base[:, :3], torch.zeros_like(base[:, :3]))
    return stored
