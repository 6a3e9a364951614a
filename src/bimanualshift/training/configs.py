"""The typed configs of the training commands (`pretrain`, `train`, `refine`), nested by what they set: the data,
the network, the optimisation. Nothing heavy is imported here, so `--help` answers at once; every field of every
group is one command-line flag (the group's name is not part of it), and a flat config of an older run still
reads (``utils.config_files.config_from_dict``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

from bimanualshift.configs import DEFAULT_PRIOR, RESIDUAL_STEPS

if TYPE_CHECKING:
    from bimanualshift.residual.manager import ResidualConfig

ARM_ORDER = ("left", "right")  # the Manager's arm one-hot; single-arm data counts as "left"


@dataclass
class OptimConfig:
    """How a network is optimised: steps, batch, learning rate, optimiser, checkpoints and the run's seed."""

    steps: int = 1500
    batch_size: int = 4  # the global batch (split over torchrun's processes)
    lr: float = 1e-3
    optimizer: str = "lamb"  # lamb (PerAct, the paper) or adamw (Diffusion Policy)
    checkpoint_every: int = 250
    seed: int = 0
    schedule: str = "constant"  # constant, or cosine: linear warm-up, then cosine decay to 5 % of lr
    warmup_steps: int = 0  # steps of linear warm-up (cosine only)
    # Early stopping: end the run once this many checkpoints in a row have not improved on the best validation
    # value (0: run every step). The best checkpoint is what the run hands on either way.
    patience: int = 0
    # training curves: tensorboard (event files in OUT/tensorboard) or wandb (offline unless WANDB_MODE says)
    log: Literal["none", "tensorboard", "wandb"] = "none"


@dataclass
class PriorDataConfig:
    """The single-arm demos a prior learns from, and how they are augmented."""

    tasks: list[str] = field(default_factory=lambda: ["unimanual"])  # task names or the group 'unimanual'
    data: str = "data/unimanual"
    validation_data: str = "data/unimanual_val"
    episodes_per_task: int = 0  # train on each task's first N demos by seed (0: all of them; the data-volume study)
    augment_translation_m: float = 0.04  # SE(3) augmentation: horizontal shift ...
    augment_yaw_deg: float = 15.0  # ... and yaw about the grid's vertical axis; 0 and 0 turn it off


@dataclass
class PriorNetworkConfig:
    """Which network: a registered prior type, a named size, and field overrides on top."""

    prior: str = "peract"  # a registered prior type: peract, dp (= diffusion) or act
    size: str = "default"  # a named model size from bimanualshift.configs (default, debug, ...)
    model: dict = field(default_factory=dict)  # overrides of the prior's config fields, e.g. {"dim": 64}
    # Continue from a trained prior (a folder or a shipped name): its architecture, weights and normalisation
    # (type and size are then read from it, ``model`` overrides fields that keep the weights' shapes, e.g.
    # {"num_points": 16384}); a run of its own, with a fresh optimiser and schedule.
    init_from: str = ""


@dataclass
class PretrainConfig:
    """`bimanualshift pretrain`: data, network and optimisation of a single-arm prior. Every field of every group
    is one flag (``--prior``, ``--tasks``, ``--steps``, ...); a flat config of an older run still reads."""

    out: str = "runs/prior"
    dataset: PriorDataConfig = field(default_factory=PriorDataConfig)
    network: PriorNetworkConfig = field(default_factory=PriorNetworkConfig)
    optim: OptimConfig = field(default_factory=lambda: OptimConfig(steps=3000, lr=1e-3))


@dataclass
class ResidualDataConfig:
    """The bimanual demos the residual learns from."""

    task: str = "push_two_buttons"
    data: str = "data/bimanual"
    validation_data: str = "data/bimanual_val"
    demos: int = 20
    # The paper's SE(3) augmentation: copies of every demo keyframe under a random yaw about the grid's vertical
    # axis and a horizontal shift (targets, both arms' poses, the goal and the reference move with the scene),
    # each passed through the frozen prior once and cached (0: no augmentation). No yaw by default: on validation
    # demos a 15 deg yaw made the residual's pose error 5x worse (results/residual_variants.json, docs/residual.md).
    augment_copies: int = 8
    augment_translation_m: float = 0.04
    augment_yaw_deg: float = 0.0


@dataclass
class ResidualModelConfig:
    """What the residual reads, and how the frozen prior's observation is made."""

    use_projection: bool = True
    segmenter: str = "simulator"  # simulator | grounded_sam | degraded-mild | degraded-strong
    grounding_dino: str = ""  # grounded_sam only: local save_pretrained folder or hub id (empty: the default)
    sam: str = ""  # grounded_sam only: local folder or hub id of SAM (empty: the default)
    structured: bool = True
    retrieval: bool = False  # the memory bank's temporal reference as a Manager input (Eq. 8-9)
    retrieval_threshold: float = 0.5  # cosine similarity below which no reference is used
    text_encoder: str = "minilm"  # the residual's instruction / skill-verb encoder: minilm | clip | clip:<dir>
    # The goal's location (centroid and extent in the arm's frame, from the projection's goal segmentation) as a
    # Manager input; with --use-projection false the goal is still segmented for it, only the masking is off.
    goal_geometry: bool = True
    # The goal geometry also gives the goal's two extremities (tip and direction of each end, this arm's end
    # first: perception/goal_geometry.py); off: its box alone (10 numbers).
    goal_extremities: bool = True
    # Each goal noun's own box too (up to three, in the nouns' order: the tray's beside the oven's), where the
    # union's box lets the larger object hide the smaller (perception/goal_geometry.py).
    goal_objects: bool = False
    # The goal geometry at the episode's first keyframe too (its union and each goal noun's box), read at every
    # keyframe: where the goal lay before the arms moved or hid it (the dirt a brush covers).
    goal_at_start: bool = False
    phase_slots: int = 25  # keyframe slots per arm of the (arm, keyframe) one-hot Manager input (0: none)
    # The one-hot's blocks are (role, arm) pairs: the arm that moves first leads, decided per episode from what the
    # arms see at its first keyframe (methods/role_assigner.py), so a layout that swaps the arms' parts (take tray)
    # does not average two roles' targets in one slot. Needs --phase-slots > 0. Where each arm plays one role in
    # every demo the run keeps the per-arm slots (the same residual). Chosen on validation seeds (docs/residual.md).
    roles: bool = True
    # Width of the Manager's two hidden layers (the residual's size: docs/residual-variants.md, "The Manager's width").
    hidden: int = 256
    normalise_inputs: bool = True  # standardise the Manager's inputs with the training inputs' statistics
    # The Manager's trunk reads the frozen prior's pooled features too; off: they let it memorise the demos.
    prior_features: bool = False
    geometric_skip: bool = True  # a linear path from goal, proprio, prior action and phase into h
    # After training, scale the residual's translation and rotation by factors chosen on the validation demos
    # (residual/output_gate.py): the residual is turned down where the prior alone places keyframes better.
    output_gate: bool = True
    gate_per_keyframe: bool = False  # the gate's factors chosen per keyframe slot (needs --phase-slots > 0)
    # The paper-literal residual of Eq. 4: translation and rotation only. Off (the default): the residual also
    # moves the prior's gripper logit and may hold an arm while the other acts (docs/residual.md).
    paper_literal: bool = False
    # The Manager reads the frozen prior's features at and around its own proposal (Eq. 6's arm-specific visual
    # input: the voxel prior's maps at its heat-map peak and one voxel around, the RVT prior's per-view maps).
    proposal_features: bool = True
    # The action-space residual: logits added to the prior's translation heat-map (on a lattice of action_window^3
    # cells action_cell_m apart around its proposal) and rotation bins, instead of a continuous move (Eq. 4).
    action_space: bool = False
    action_window: int = 9
    action_cell_m: float = 0.02
    # The sign of the quaternions the Manager reads: "gripper_down" keeps them on the gripper-down pose's side,
    # "w_positive" as the environment gives them (w >= 0, which flips at random near the gripper-down pose; half
    # the demos' poses). Chosen on validation seeds (docs/residual.md).
    quaternion_sign: str = "gripper_down"
    # What the rotation residual is trained towards: "expert" (the demos' orientation) or "nearest_twin" (the
    # expert's or its twin half a turn about the gripper's approach axis, the same parallel grasp, whichever is
    # nearer the prior's proposal: the demos' wrist yaw is wrapped into a half turn, so a grasp at the wrap's edge
    # comes as either twin at random, and the residual averages the two turns; docs/residual-variants.md), or
    # "slot_twin" (the twin nearer the training demos' mean grasp at the same arm and keyframe slot).
    rotation_target: str = "expert"
    # The heading anchor (residual/heading_anchor.py): where the demos grasp at a fixed orientation relative to the
    # goal's end direction, the base orientation turns with that direction instead of being the prior's.
    heading_anchor: bool = False
    # What the frozen prior is asked: "" the episode's own instruction (the paper), "auto" the instruction of the
    # prior's pretraining suite whose proposals lie closest to the training demos' keyframes when it clearly beats
    # the task's own (training/prior_instruction.py), "per_arm" per arm the instruction a classifier picks from
    # what the arm observes (fitted on the training demos: an arm's skill follows its role), any other text that
    # instruction. The Manager and the memory keep the episode's instruction.
    prior_instruction: str = ""

    def residual_config(self, feature_dim: int, text_dim: int, proposal_dim: int = 0,
                        rotation_bins: int = 0) -> ResidualConfig:
        """The network's config: the one place these switches become the residual's widths and flags
        (``ResidualConfig``'s own defaults are what a checkpoint written before a field existed meant)."""
        from bimanualshift.memory.reference import REFERENCE_DIM
        from bimanualshift.perception.goal_geometry import BOX_GEOMETRY_DIM, GOAL_GEOMETRY_DIM, UNION_GEOMETRY_DIM
        from bimanualshift.residual.manager import NUM_ROLES, ResidualConfig

        if self.hidden < 1:
            raise ValueError(f"--hidden must be a positive layer width, got {self.hidden}")
        return ResidualConfig(feature_dim=feature_dim, text_dim=text_dim, structured=self.structured,
                              hidden=self.hidden,
                              reference_dim=REFERENCE_DIM if self.retrieval else 0,
                              goal_dim=(GOAL_GEOMETRY_DIM if self.goal_objects
                                        else UNION_GEOMETRY_DIM if self.goal_extremities else BOX_GEOMETRY_DIM)
                              if self.goal_geometry else 0,
                              phase_dim=self.phase_slots * len(ARM_ORDER) * (NUM_ROLES if self.roles else 1),
                              role_phase=self.roles and self.phase_slots > 0, normalise_inputs=self.normalise_inputs,
                              read_prior_features=self.prior_features, geometric_skip=self.geometric_skip,
                              # the gate scales continuous moves; an action-space residual makes none
                              output_gate=self.output_gate and not self.action_space,
                              gate_per_keyframe=self.gate_per_keyframe and self.output_gate and not self.action_space,
                              gripper_residual=not self.paper_literal, hold=not self.paper_literal,
                              proposal_dim=proposal_dim if self.proposal_features else 0,
                              action_space=self.action_space, action_window=self.action_window,
                              action_cell_m=self.action_cell_m,
                              rotation_bins=rotation_bins if self.action_space else 0,
                              quaternion_sign=self.quaternion_sign, rotation_target=self.rotation_target,
                              start_goal_dim=GOAL_GEOMETRY_DIM if self.goal_at_start else 0,
                              heading_anchor=self.heading_anchor)


@dataclass
class TrainConfig:
    """`bimanualshift train`: the frozen prior, the demos, the residual's inputs and the optimisation. Every field
    of every group is one flag (``--task``, ``--retrieval``, ``--steps``, ...); a flat config of an older run
    still reads (``--config``)."""

    prior: str = DEFAULT_PRIOR  # a shipped name or a checkpoint folder
    out: str = "runs/bimanualshift"
    # Continual learning: an earlier BimanualShift run (or its checkpoint) whose Manager, Z and G start this run
    # and whose memory bank entries join this task's, so earlier tasks stay retrievable.
    init_from: str = ""
    # weight of the rotation term in L_BC (Eq. 12): rad^2 against m^2, so 0.01 weighs 0.1 rad as 1 cm (chosen on
    # validation seeds, docs/residual.md; 1 let the rotation drown the translation)
    beta: float = 0.01
    # What picks the best checkpoint on the validation demos: "pose_loss", L_BC's pose part (translation + beta *
    # rotation, squared), or "clipped_error", the output gate's measure: mean translation error clipped at 5 cm
    # over 5 cm plus mean rotation error clipped at 20 degrees over 20 degrees (each in [0, 1]; with beta = 1 the
    # squared rotation outweighs a centimetre's translation a hundredfold).
    select_by: str = "clipped_error"
    # Closed-loop checkpoint choice (training/closed_loop_choice.py): > 0 keeps the checkpoint with the lowest
    # select_by value in each of select_candidates equal stretches of the run, rolls each out on this many
    # validation scenes after training and hands on the one that succeeds most (ties: more stages, then the lower
    # value). 0: the lowest value alone decides.
    select_rollouts: int = 0
    select_candidates: int = 4
    select_workers: int = 1  # processes rolling the candidates out (the same outcomes whatever the number)
    select_max_keyframes: int = 0  # the selection rollouts' episode length limit (0: the task's)
    gripper_weight: float = 0.01  # weight of the gripper logit's cross-entropy in L_BC (not paper-literal)
    hold_weight: float = 0.01  # weight of the hold logit's cross-entropy in L_BC (not paper-literal)
    dataset: ResidualDataConfig = field(default_factory=ResidualDataConfig)
    model: ResidualModelConfig = field(default_factory=ResidualModelConfig)
    # LAMB at 1e-3 decayed on a cosine to 5 % over the run, every step kept (the best checkpoint is picked by
    # select_by): what the benchmark validated (docs/residual.md); the paper's constant 5e-4 left the last
    # iterates noisy at batch 4.
    optim: OptimConfig = field(default_factory=lambda: OptimConfig(steps=RESIDUAL_STEPS, lr=1e-3, schedule="cosine",
                                                                   patience=0))


@dataclass
class RefineConfig:
    checkpoint: str = "runs/bimanualshift/best"  # a trained BimanualShift (from `bimanualshift train`)
    out: str = "runs/refine"
    episodes: int = 20  # training scenes rolled out
    start: int = 0  # first train-split seed offset (0: the demos' own scenes)
    max_keyframes: int = 0  # episode length limit of the policy's own rollouts (0: the task's)
    tolerance_m: float = 0.03  # an arm strays when its position is this far from the corrector's ...
    tolerance_deg: float = 20.0  # ... or its orientation this far, or its gripper state differs
    lambda_corr: float = 1.0  # weight of L_corr in L_total (Eq. 13)
    steps: int = 500
    batch_size: int = 4
    lr: float = 5e-4
    beta: float = 0.0  # the rotation term's weight in L_BC and L_corr; 0: the one the checkpoint was trained with
    gripper_weight: float = 0.01  # as in `train`: the gripper's and the hold's cross-entropy weights
    hold_weight: float = 0.01
    checkpoint_every: int = 100
    seed: int = 0
    workers: int = 1  # processes rolling the scenes out (the same scenes and result whatever the number)
    # the successes added to the memory: "all" (the paper's Eq. 11: the policy's own and the corrected ones),
    # "corrected" (only those the expert corrected: a reference from the policy's own success repeats where the
    # policy already goes) or "none" (the memory keeps the demos alone)
    memory_insert: Literal["all", "corrected", "none"] = "all"
    log: Literal["none", "tensorboard", "wandb"] = "none"  # training curves, as `train --log`
    # another refinement folder whose scenes were rolled out from the same checkpoint with the same rollout
    # settings: its finished scenes are reused instead of rolled out again (variants differing only after the
    # rollouts, such as memory_insert, share them)
    scenes_from: str = ""
    # validation scenes rolled out and corrected the same way (validation-split seeds from validation_start: past
    # the validation demos', short of the benchmark's validation rollouts at 10,000): their corrections join the
    # validation loss that picks the fine-tuning step (Eq. 13 on held-out scenes); their successes stay out of the
    # memory. 0: the step is picked on the validation demos' L_BC alone
    validation_episodes: int = 0
    validation_start: int = 5_000
