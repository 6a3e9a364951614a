"""The Manager network (Eq. 6), the projection G and the residual action (Eq. 4, 7)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from bimanualshift.geometry.torch_rotations import quat_toward
from bimanualshift.residual.heading_anchor import ANCHOR_WIDTH
from bimanualshift.residual.skills import SkillBasis

QUATERNION_SIGNS = ("w_positive", "gripper_down")
ROTATION_TARGETS = ("expert", "nearest_twin", "slot_twin")


@dataclass
class ResidualConfig:
    num_skills: int = 16
    hidden: int = 256
    feature_dim: int = 208  # the prior's visual feature width
    proprio_dim: int = 9  # own arm (8) + keyframe fraction
    other_proprio_dim: int = 8
    text_dim: int = 384
    base_action_dim: int = 8  # the prior's own action (arm frame): xyz, quaternion, gripper
    num_arms: int = 2
    structured: bool = True  # False: an MLP residual with no skill basis (ablation)
    reference_dim: int = 0  # width of the retrieved temporal reference; 0 = no retrieval (ablation)
    goal_dim: int = 0  # width of the projection's goal geometry; 0 = not read (checkpoints from before it)
    phase_dim: int = 0  # (arm, keyframe index) as one one-hot of this width (num_arms x slots); 0 = none
    # Standardise the Manager's input with statistics of the training inputs (stored with the weights).
    normalise_inputs: bool = False
    # The Manager's trunk reads the prior's pooled visual features (False: the goal geometry is its visual input).
    read_prior_features: bool = True
    # h gains a linear path from the geometric inputs (goal, own proprio, the prior's action, arm-keyframe one-hot).
    geometric_skip: bool = False
    # The residual's translation and rotation are scaled by factors chosen on validation demos after training
    # (``output_scale``; 1 while training): where the prior is already precise, the residual is turned down.
    output_gate: bool = False
    # One (translation, rotation) factor pair per keyframe slot of the phase one-hot instead of one for all: the
    # residual can be kept where it corrects a far-off prior (a carry the prior never saw) and turned down where
    # the prior is already precise (a grasp). Needs ``phase_dim``.
    gate_per_keyframe: bool = False
    # Coordination outputs beyond the paper's Eq. 4 (both False: the paper-literal residual, translation and
    # rotation only). ``gripper_residual``: a logit added to the prior's open/close logit. ``hold``: a logit that,
    # when positive, keeps the arm where its last action put it while the other arm acts.
    gripper_residual: bool = False
    hold: bool = False
    # Width of the frozen prior's features at and around its own proposal (``PriorOutput.proposal_features``), the
    # arm-specific visual input of Eq. 6; 0 = not read (checkpoints from before it).
    proposal_dim: int = 0
    # The action-space residual (docs/residual-variants.md): instead of moving the prior's action continuously
    # (Eq. 4), G adds logits to the prior's own distributions: its translation log-probabilities on a lattice of
    # ``action_window``^3 cells ``action_cell_m`` apart centred on its proposal, and its rotation bins
    # (``rotation_bins`` per Euler axis, the prior's). The final action is the arg-max of the sums.
    action_space: bool = False
    action_window: int = 9
    action_cell_m: float = 0.02
    rotation_bins: int = 0
    # The sign of every quaternion the Manager reads (own and other arm's pose, the prior's action, the reference):
    # "w_positive" as the environment gives it (checkpoints from before the choice), or "gripper_down": on the side
    # of the gripper-down pose, where w is near 0 and the w >= 0 sign flips at random between similar poses.
    quaternion_sign: str = "w_positive"
    # Width of the goal geometry as the episode's first keyframe saw it, read beside the current one: where things
    # lay before the arms moved or hid them (dirt under the brush); 0 = not read (checkpoints from before it).
    start_goal_dim: int = 0
    # The orientation the rotation residual is trained towards, here so that refinement's corrections use the same:
    # "expert" as the demos give it, or "nearest_twin": the expert's or its twin half a turn about the gripper's
    # approach axis (the same parallel grasp), whichever is nearer the prior's proposal (geometry.frames), or
    # "slot_twin": the twin nearer the training demos' mean grasp at the same arm and keyframe slot.
    rotation_target: str = "expert"
    # "slot_twin"'s mean grasps, one quaternion per (arm, keyframe slot) of the phase one-hot, flattened (arm-major);
    # taken from the training demos, kept so that refinement's corrections turn towards the same twins.
    twin_references: tuple[float, ...] = ()
    # The phase one-hot's blocks are (role, arm) pairs instead of arms: which part of a bimanual task each arm plays
    # (role 0 leads: it moves first) changes with the scene in tasks whose layout decides it (take tray: the arm on
    # the tray's side takes it), and one block per arm name would average the two roles' keyframe targets.
    # ``methods/role_assigner.py`` decides the roles at an episode's first keyframe; the demos' give the labels.
    role_phase: bool = False
    # The heading anchor (residual/heading_anchor.py): at the phase slots where the demos grasp steadier (on the
    # table, or relative to the goal's end direction) than the prior proposes, the base orientation is the demos'
    # mean grasp instead of the prior's (training, refinement and inference alike). ``heading_anchors`` holds, per
    # phase slot, the frame and the mean grasp (``ANCHOR_WIDTH`` numbers; zeros: not anchored), fitted on the
    # training demos.
    heading_anchor: bool = False
    heading_anchors: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if self.quaternion_sign not in QUATERNION_SIGNS:
            raise ValueError(f"quaternion_sign is one of {', '.join(QUATERNION_SIGNS)}, got {self.quaternion_sign!r}")
        if self.rotation_target not in ROTATION_TARGETS:
            raise ValueError(f"rotation_target is one of {', '.join(ROTATION_TARGETS)}, got {self.rotation_target!r}")
        if self.rotation_target == "slot_twin" and not self.phase_dim:
            raise ValueError("rotation_target 'slot_twin' picks each grasp's twin per keyframe slot: it needs the "
                             "phase one-hot (--phase-slots > 0)")
        if self.heading_anchor and not (self.phase_dim and self.goal_dim):
            raise ValueError("the heading anchor fits one orientation per keyframe slot from the goal's direction: it "
                             "needs the phase one-hot (--phase-slots > 0) and the goal geometry (--goal-geometry)")
        if self.heading_anchors and len(self.heading_anchors) != ANCHOR_WIDTH * self.phase_dim:
            raise ValueError(f"heading_anchors holds {len(self.heading_anchors)} numbers; a frame and a quaternion per "
                             f"slot of the phase one-hot is {ANCHOR_WIDTH * self.phase_dim}")
        if self.twin_references and len(self.twin_references) != 4 * self.num_arms * self.slots_per_arm:
            raise ValueError(f"twin_references holds {len(self.twin_references)} numbers; a quaternion per (arm, "
                             f"keyframe slot) of the phase one-hot is {4 * self.num_arms * self.slots_per_arm}")

    @property
    def phase_blocks(self) -> int:
        """Blocks of keyframe slots in the phase one-hot: one per arm, or per (role, arm) with ``role_phase``."""
        return self.num_arms * (NUM_ROLES if self.role_phase else 1)

    @property
    def slots_per_arm(self) -> int:
        """Keyframe slots each block of the phase one-hot has (0 without one)."""
        return self.phase_dim // self.phase_blocks

    def phase_slot(self, keyframe: np.ndarray | torch.Tensor) -> np.ndarray | torch.Tensor:
        """Each keyframe index's slot in its arm's block: keyframes past the end share the last slot."""
        last = self.slots_per_arm - 1
        return keyframe.long().clamp(0, last) if isinstance(keyframe, torch.Tensor) else np.clip(keyframe, 0, last)

    def twin_reference(self, arm: int, slot: int) -> np.ndarray:
        """``slot_twin``'s mean grasp (x, y, z, w) for an arm and keyframe slot."""
        if not self.twin_references:
            raise ValueError("this residual has no twin references: they are set from the training demos before "
                             "its targets are built (training.residual_data.residual_data)")
        start = 4 * (arm * self.slots_per_arm + slot)
        return np.asarray(self.twin_references[start:start + 4], dtype=np.float64)

    @property
    def gate_slots(self) -> int:
        """Rows of ``output_scale``: one per keyframe slot with ``gate_per_keyframe``, else 1."""
        return self.slots_per_arm if self.gate_per_keyframe else 1

    @property
    def lattice_cells(self) -> int:
        return self.action_window**3 if self.action_space else 0

    @property
    def extra_outputs(self) -> int:
        """G's outputs beyond the 6 of Eq. 4 (translation, rotation)."""
        return int(self.gripper_residual) + int(self.hold) + self.lattice_cells + 3 * self.rotation_bins * int(
            self.action_space)

    def layout(self) -> dict[str, slice]:
        """Where each part of ``manager_inputs``'s row lies."""
        widths = {"features": self.feature_dim, "proprio": self.proprio_dim, "other_proprio": self.other_proprio_dim,
                  "text": self.text_dim, "base_action": self.base_action_dim, "arm": self.num_arms,
                  "reference": self.reference_dim, "goal": self.goal_dim, "phase": self.phase_dim,
                  "proposal": self.proposal_dim, "start_goal": self.start_goal_dim}
        out, start = {}, 0
        for name, width in widths.items():
            out[name] = slice(start, start + width)
            start += width
        return out


NUM_ROLES = 2  # 0: the arm that leads (moves first), 1: the arm that follows (methods/role_assigner.py)
HOLD_INIT_LOGIT = -4.0
GRIPPER_PROB_FLOOR = 1e-4  # the prior's open probability is clamped here before its logit is taken
INPUT_STD_FLOOR = 1e-2  # below this spread a column is treated as constant (e.g. one instruction's embedding)


class Manager(nn.Module):
    """(omega, h) = Manager(features, both arms' proprio, instruction) with softmax-normalised omega."""

    def __init__(self, config: ResidualConfig, skill_dim: int) -> None:
        super().__init__()
        c = config
        layout = c.layout()
        self.in_dim = layout["start_goal"].stop
        columns = torch.arange(self.in_dim)
        if not c.read_prior_features:
            columns = columns[layout["features"].stop:]
        self.register_buffer("trunk_columns", columns, persistent=False)
        self.trunk = nn.Sequential(nn.Linear(len(columns), c.hidden), nn.GELU(), nn.Linear(c.hidden, c.hidden),
                                   nn.GELU())
        self.weights = nn.Linear(c.hidden, c.num_skills)
        self.compensation = nn.Linear(c.hidden, skill_dim)
        self.skip: nn.Linear | None = None
        if c.geometric_skip:
            parts = ("goal", "proprio", "base_action", "phase", "start_goal")
            skip = torch.cat([torch.arange(self.in_dim)[layout[k]] for k in parts])
            self.register_buffer("skip_columns", skip, persistent=False)
            self.skip = nn.Linear(len(skip), skill_dim)

    def forward(self, inputs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = self.trunk(inputs[:, self.trunk_columns])
        compensation = self.compensation(x)
        if self.skip is not None:  # a linear map of where the goal, the arm and the prior's proposal are
            compensation = compensation + self.skip(inputs[:, self.skip_columns])
        return self.weights(x).softmax(-1), compensation


class ResidualPolicy(nn.Module):
    """The only learned part: Manager, skill basis Z and G. G maps v to a translation (3) and an
    axis-angle rotation (3) residual; the rotation is composed with the prior's on SO(3)."""

    def __init__(self, config: ResidualConfig, basis: SkillBasis) -> None:
        super().__init__()
        self.config = config
        self.basis = basis
        skill_dim = basis.z.shape[1]
        self.manager = Manager(config, skill_dim)
        if config.normalise_inputs:
            self.register_buffer("input_mean", torch.zeros(self.manager.in_dim))
            self.register_buffer("input_std", torch.ones(self.manager.in_dim))
        if config.gate_per_keyframe and not (config.output_gate and config.phase_dim):
            raise ValueError("gate_per_keyframe needs output_gate and a phase one-hot (phase_dim > 0)")
        if config.output_gate:  # (translation, rotation) factors, per keyframe slot or one row; choose_output_scale
            self.register_buffer("output_scale", torch.ones(2) if not config.gate_per_keyframe
                                 else torch.ones(config.gate_slots, 2))
        self.g = nn.Linear(skill_dim, 6 + config.extra_outputs)
        nn.init.zeros_(self.g.weight)  # start as the identity: the prior's action unchanged ...
        nn.init.zeros_(self.g.bias)
        if config.hold:  # ... and no arm held (a hold logit of -4 is a 2 % hold probability)
            with torch.no_grad():
                self.g.bias[6 + int(config.gripper_residual)] = HOLD_INIT_LOGIT

    @torch.no_grad()
    def fit_normalisation(self, inputs: torch.Tensor) -> None:
        """Set the input statistics from the training inputs; a column spread less than INPUT_STD_FLOOR is divided
        by the floor instead (a constant column, such as one task's instruction embedding, becomes zeros)."""
        if not self.config.normalise_inputs:
            raise ValueError("this residual was built with normalise_inputs=False")
        self.input_mean.copy_(inputs.mean(0))
        self.input_std.copy_(inputs.std(0).clamp_min(INPUT_STD_FLOOR))

    def forward(self, inputs: torch.Tensor) -> dict[str, torch.Tensor]:
        """``translation`` (N, 3) and ``rotation`` (N, 3) residuals (Eq. 4); with ``gripper_residual`` the final
        open/close logit ``gripper_logit`` (N,) = the prior's logit + the residual's; with ``hold`` the hold logit
        ``hold_logit`` (N,); the skill weights and v."""
        c = self.config
        prior_gripper = inputs[:, c.layout()["base_action"].start + 7]  # the prior's open probability, raw
        slot = keyframe_slots(c, inputs) if c.gate_per_keyframe else None
        if c.normalise_inputs:
            inputs = (inputs - self.input_mean) / self.input_std
        weights, compensation = self.manager(inputs)
        v = self.basis.combine(weights, compensation) if c.structured else compensation
        residual = self.g(v)
        translation, rotation = residual[:, :3], residual[:, 3:6]
        if c.output_gate:
            scale = self.output_scale[slot] if slot is not None else self.output_scale[None]  # (N or 1, 2)
            translation, rotation = translation * scale[:, :1], rotation * scale[:, 1:]
        out = {"translation": translation, "rotation": rotation, "weights": weights, "v": v}
        column = 6
        if c.gripper_residual:
            p = prior_gripper.clamp(GRIPPER_PROB_FLOOR, 1 - GRIPPER_PROB_FLOOR)
            out["gripper_logit"] = torch.log(p) - torch.log1p(-p) + residual[:, column]
            column += 1
        if c.hold:
            out["hold_logit"] = residual[:, column]
            column += 1
        if c.action_space:  # logits added to the prior's lattice scores and rotation bins
            out["translation_logits"] = residual[:, column: column + c.lattice_cells]
            column += c.lattice_cells
            out["rotation_logits"] = residual[:, column: column + 3 * c.rotation_bins].view(-1, 3, c.rotation_bins)
        return out


def keyframe_slots(config: ResidualConfig, inputs: torch.Tensor) -> torch.Tensor:
    """(N,) each raw Manager input row's keyframe slot, read from its (arm, keyframe) phase one-hot."""
    return arm_and_slot(config, inputs)[1]


def arm_and_slot(config: ResidualConfig, inputs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(N,) each raw Manager input row's arm index and (N,) its keyframe slot, read from its (arm, keyframe) phase
    one-hot (arm-major: one block of slots per arm)."""
    phase = inputs[:, config.layout()["phase"]].argmax(-1)
    return (phase // config.slots_per_arm) % config.num_arms, phase % config.slots_per_arm


def action_lattice(config: ResidualConfig) -> torch.Tensor:
    """(W^3, 3) the action-space residual's cell offsets from the prior's proposal (metres); the centre cell,
    index W^3 // 2, is the proposal itself."""
    w = config.action_window
    if w < 1 or w % 2 == 0:
        raise ValueError(f"action_window must be odd and >= 1, got {w}")
    steps = (torch.arange(w, dtype=torch.float32) - w // 2) * config.action_cell_m
    return torch.stack(torch.meshgrid(steps, steps, steps, indexing="ij"), -1).reshape(-1, 3)


def manager_inputs(features: torch.Tensor, proprio: torch.Tensor, other_proprio: torch.Tensor,
                   text: torch.Tensor, base_action: torch.Tensor, arm_index: torch.Tensor, num_arms: int,
                   reference: torch.Tensor | None = None, goal: torch.Tensor | None = None,
                   phase: torch.Tensor | None = None, proposal: torch.Tensor | None = None,
                   start_goal: torch.Tensor | None = None) -> torch.Tensor:
    """The Manager's input row: the arm's visual features, both arms' proprioception, the instruction, the
    prior's own action, the arm's one-hot, (with retrieval) the retrieved temporal reference and (when the
    residual reads them) the goal's location from the projection, the (arm, keyframe) one-hot ``phase``, the
    prior's features at and around its proposal and the goal's location at the episode's first keyframe."""
    parts = [features, proprio, other_proprio, text, base_action, nn.functional.one_hot(arm_index, num_arms).float()]
    for part in (reference, goal, phase, proposal, start_goal):
        if part is not None:
            parts.append(part)
    return torch.cat(parts, dim=-1)


def manager_input_rows(config: ResidualConfig, features: torch.Tensor, proprio: torch.Tensor,
                       other_proprio: torch.Tensor, text: torch.Tensor, base_action: torch.Tensor,
                       arm_index: torch.Tensor, keyframe: torch.Tensor, reference: torch.Tensor | None = None,
                       goal: torch.Tensor | None = None, proposal: torch.Tensor | None = None,
                       start_goal: torch.Tensor | None = None, role: torch.Tensor | None = None) -> torch.Tensor:
    """(N, width) Manager input rows exactly as ``config`` reads them (``config.layout()``): training, refinement
    and inference all build their rows here. The retrieved reference, the goal geometry, the prior's proposal
    features, the episode's first goal geometry and (with ``role_phase``) each row's role must be given when the
    config reads them; the (arm, keyframe) phase one-hot is derived from ``keyframe``."""
    if config.goal_dim and goal is not None and goal.shape[-1] > config.goal_dim:
        goal = goal[..., :config.goal_dim]  # a residual trained before the extremities reads the box alone
    if config.start_goal_dim and start_goal is not None and start_goal.shape[-1] > config.start_goal_dim:
        start_goal = start_goal[..., :config.start_goal_dim]
    for name, width, value in (("reference", config.reference_dim, reference), ("goal", config.goal_dim, goal),
                               ("proposal", config.proposal_dim, proposal),
                               ("first keyframe's goal", config.start_goal_dim, start_goal)):
        if width and value is None:
            raise ValueError(f"this residual reads a {width}-wide {name}; pass it to build the Manager's input")
        if width and value.shape[-1] != width:
            raise ValueError(f"this residual reads a {width}-wide {name}, got {value.shape[-1]} columns: the "
                             "prior is not the one it was trained with")
    if config.quaternion_sign == "gripper_down":
        proprio, other_proprio, base_action = (_quaternion_toward_gripper_down(x)
                                               for x in (proprio, other_proprio, base_action))
        reference = None if reference is None else _quaternion_toward_gripper_down(reference)
    if config.role_phase and config.phase_dim and role is None:
        raise ValueError("this residual's phase one-hot is per (role, arm): pass each row's role "
                         "(methods/role_assigner.py) to build the Manager's input")
    phase = phase_one_hot(config, keyframe, arm_index, role) if config.phase_dim else None
    return manager_inputs(features, proprio, other_proprio, text, base_action, arm_index, config.num_arms,
                          reference if config.reference_dim else None, goal if config.goal_dim else None, phase,
                          proposal if config.proposal_dim else None,
                          start_goal if config.start_goal_dim else None)


def _quaternion_toward_gripper_down(rows: torch.Tensor) -> torch.Tensor:
    """``rows`` (..., >= 7: xyz, quaternion x y z w, ...) with each quaternion on the gripper-down side."""
    return torch.cat([rows[..., :3], quat_toward(rows[..., 3:7]), rows[..., 7:]], dim=-1)


def phase_one_hot(config: ResidualConfig, keyframe: torch.Tensor, arm_index: torch.Tensor,
                  role: torch.Tensor | None = None) -> torch.Tensor:
    """(N, phase_dim) the (arm, keyframe index) pair as one one-hot over ``num_arms`` blocks of
    ``slots_per_arm`` slots: each arm's keyframes get their own slots (``phase_slot``); with ``role_phase`` the
    blocks are (role, arm) pairs, role-major."""
    slots, width = config.slots_per_arm, config.phase_dim
    if slots < 1 or slots * config.phase_blocks != width:
        raise ValueError(f"a phase one-hot of width {width} does not split into {config.phase_blocks} blocks")
    block = arm_index.long()
    if config.role_phase:
        block = block + config.num_arms * torch.as_tensor(role).long().reshape(block.shape)
    index = block * slots + config.phase_slot(keyframe)
    return nn.functional.one_hot(index, width).float()
