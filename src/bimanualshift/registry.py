"""Every method the benchmark compares, by name: its trainer, its typed training config and its loader.

Methods share the task, data and rollout code; a method only says what differs (diffusion_policy's split of
tasks and methods: N tasks + M methods cost N + M code). The ablations are the full method with one switch off.
The registry sits above both the policies (``methods``) and their trainers (``training``), which it pairs.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from bimanualshift.configs import RESIDUAL_STEPS
from bimanualshift.core.policy import Policy
from bimanualshift.training.baseline_configs import BackboneTrainConfig, LeaderFollowerTrainConfig
from bimanualshift.training.request import TrainRequest

DEFAULT_TRAIN_STEPS = 1500  # for methods that name no steps of their own

# Refinement inside the benchmark (Eq. 10-11, 13): rollouts on this many training scenes after the demos' own
# (train-split seeds, never validation or test), the expert correcting failures; request overrides
# ``refine_episodes`` / ``refine_steps`` change them.
REFINE_EPISODES = 20
REFINE_FOLDER = "refine"  # under the method's run directory: its rollouts, checkpoints and summary.json


@dataclass(frozen=True)
class MethodSpec:
    name: str
    description: str
    train: Callable[[TrainRequest], Path | None]  # the checkpoint to evaluate; None when nothing is trained
    load: Callable[[Path | None, TrainRequest], Policy]
    # Continual learning: the method can start from its own earlier run on another task (the request's
    # ``overrides["init_from"]`` names that run's folder).
    continual: bool = False
    steps: int = DEFAULT_TRAIN_STEPS  # its default training steps
    config: Any = None  # its default typed training config (a dataclass the request's overrides are applied to)
    refine: bool = False  # training ends with refinement on training scenes (``refine_*`` request overrides)
    # the method whose training run this one shares (its folder in a benchmark's runs): the full method before
    # refinement is the full method's own trained residual, not a second, identical training
    trains_as: str = ""
    # its refinement stage's folder under the run directory (variants refining one shared run differently each
    # keep their own)
    refine_folder: str = REFINE_FOLDER
    # what the method is in a study: the method itself (and its variants), an ablation of it, a baseline that
    # starts from a pretrained prior, or a baseline trained from scratch on the bimanual demos only
    role: str = "method"

    @property
    def run_name(self) -> str:
        """The folder under ``runs/<bench>/<task>/`` holding this method's training run."""
        return self.trains_as or self.name


METHODS: dict[str, MethodSpec] = {}
# "reference": a method a study shows for orientation that is neither an ablation nor a baseline (the frozen prior)
ROLES = ("method", "ablation", "baseline", "from_scratch", "reference")


def register_method(spec: MethodSpec) -> MethodSpec:
    if spec.name in METHODS:
        raise ValueError(f"method {spec.name!r} is already registered")
    if spec.role not in ROLES:
        raise ValueError(f"method {spec.name!r}: role {spec.role!r} is not one of {', '.join(ROLES)}")
    METHODS[spec.name] = spec
    return spec


def get_method(name: str) -> MethodSpec:
    if name not in METHODS:
        raise ValueError(f"unknown method {name!r}; choose from {sorted(METHODS)}")
    return METHODS[name]


def methods_with_role(*roles: str) -> list[str]:
    """The registered methods in any of ``roles``, in registration order (a plugin's own baselines included)."""
    return [name for name, spec in METHODS.items() if spec.role in roles]



def _finished(run: Path) -> Path | None:
    """``run``'s best checkpoint when an earlier (interrupted) benchmark run finished it, else None."""
    best = run / "best"
    return best if (run / "summary.json").is_file() and (best / "config.json").is_file() else None


# Variants measured while the keyframe slots belonged to arm names (before --roles true became the default): they
# keep the per-arm slots, so that their recorded rows (take tray's, where the roles change with the layout) stay
# reproducible. Every other method, the ablations included, follows the default.
PER_ARM_SLOT_VARIANTS = frozenset({
    "action_space", "goal_extremities", "balanced_residual", "gripper_down_quaternions", "nearest_twin", "slot_twin",
    "object_boxes", "start_goal", "augment_32", "augment_wide", "keyframe_gate", "prompted_prior",
    "role_prompted_prior", "per_arm_slots"})


def _residual_method(name: str, description: str, refine: bool = True, trains_as: str = "", role: str = "method",
                     refine_memory: str = "all", refine_validation: int = 0, **switches: Any) -> MethodSpec:
    """BimanualShift trained with ``switches`` (TrainConfig fields) on top of the request, then (``refine``)
    refined on training scenes: the method as the paper runs it. ``refine_memory`` picks the successes refinement
    adds to the memory (RefineConfig.memory_insert); ``refine_validation`` > 0 also rolls out that many validation
    scenes whose corrections help pick the fine-tuning step (RefineConfig.validation_episodes). Any other choice
    than the paper's ("all", 0) refines in a folder of its own."""
    if name in PER_ARM_SLOT_VARIANTS:
        switches = {"roles": False, **switches}
    refine_folder = REFINE_FOLDER if refine_memory == "all" else f"{REFINE_FOLDER}_{refine_memory}"
    if refine_validation:
        refine_folder += f"_validated{refine_validation}"

    def train(request: TrainRequest) -> Path:
        from bimanualshift.training.configs import RefineConfig, TrainConfig
        from bimanualshift.training.refine import refine as run_refinement
        from bimanualshift.training.residual_trainer import train_residual
        from bimanualshift.utils.config_files import config_from_flat

        own = {k: v for k, v in request.overrides.items() if not k.startswith("refine_")}
        cfg = config_from_flat(TrainConfig, task=request.task, prior=request.prior, data=request.data,
                               validation_data=request.validation_data, out=request.out, demos=request.demos,
                               steps=request.steps, seed=request.seed, log=request.log, select_workers=request.workers,
                               **{**switches, **own})
        best = _finished(Path(request.out)) or train_residual(cfg)
        if not refine:
            return best
        refined = Path(request.out) / refine_folder
        # a variant refining the shared run differently reuses the full method's rollouts where they exist
        shared = Path(request.out) / REFINE_FOLDER
        scenes_from = str(shared) if refined != shared and (shared / "refine_config.json").is_file() else ""
        return _finished(refined) or run_refinement(RefineConfig(
            checkpoint=str(best), out=str(refined), start=request.demos, seed=request.seed,
            episodes=int(request.overrides.get("refine_episodes", REFINE_EPISODES)),
            steps=int(request.overrides.get("refine_steps", RefineConfig.steps)), workers=request.workers,
            memory_insert=refine_memory, scenes_from=scenes_from, validation_episodes=refine_validation,
            log=request.log))

    def load(checkpoint: Path | None, request: TrainRequest) -> Policy:
        from bimanualshift.methods.bimanualshift import load_bimanualshift

        policy = load_bimanualshift(checkpoint)
        policy.name = name
        return policy

    return MethodSpec(name, description, train, load, continual=True, steps=RESIDUAL_STEPS, refine=refine,
                      trains_as=trains_as, refine_folder=refine_folder, role=role)


def _frozen_prior_method(name: str, description: str, use_projection: bool, role: str) -> MethodSpec:
    def load(checkpoint: Path | None, request: TrainRequest) -> Policy:
        from bimanualshift.encoders.text import default_text_encoder
        from bimanualshift.methods.frozen_prior import FrozenPriorPerArm

        return FrozenPriorPerArm.from_pretrained(request.prior, default_text_encoder(), name=name,
                                                 use_projection=use_projection)

    return MethodSpec(name, description, lambda request: None, load, role=role)


# How the residual trained before balanced_residual's settings became the default (docs/residual.md), and how
# its Manager read quaternions before gripper_down_quaternions: the variants measured then keep it, so their
# recorded rows stay reproducible.
EARLIER_QUATERNIONS: dict[str, Any] = {"quaternion_sign": "w_positive"}
EARLIER_TRAINING: dict[str, Any] = {"schedule": "constant", "beta": 1.0, "select_by": "pose_loss",
                                    **EARLIER_QUATERNIONS}

register_method(_residual_method(
    "bimanualshift", "projection + residual skill modulation + retrieval, refined on training scenes (the full "
    "method)", retrieval=True))
register_method(_residual_method(
    "no_refinement", "ablation: the full method before refinement (L_BC only; the full method's run before its "
    "refinement stage)", refine=False, trains_as="bimanualshift", retrieval=True, role="ablation"))
register_method(_residual_method(
    "corrections_memory", "variant: the full method whose refinement adds to the memory only the successes the "
    "expert corrected, not the policy's own (compare with bimanualshift and no_refinement on validation seeds)",
    trains_as="bimanualshift", retrieval=True, refine_memory="corrected"))
register_method(_residual_method(
    "fixed_memory", "variant: the full method whose refinement fine-tunes on the corrections and adds nothing to "
    "the memory, which keeps the demos alone (compare with bimanualshift and no_refinement on validation seeds)",
    trains_as="bimanualshift", retrieval=True, refine_memory="none"))
register_method(_residual_method(
    "validated_refinement", "variant: the full method whose refinement also rolls out 10 validation scenes; their "
    "corrections join the validation loss that picks the fine-tuning step, which the demos' L_BC alone sets back to "
    "the unrefined weights on most tasks (compare with bimanualshift and no_refinement on validation seeds)",
    trains_as="bimanualshift", retrieval=True, refine_validation=10))
register_method(_residual_method(
    "closed_loop_choice", "variant: the full method before refinement whose checkpoint is chosen by rollouts: the "
    "lowest validation error of each quarter of the run rolls out 30 validation scenes of its own and the most "
    "successful one is kept (compare with no_refinement on validation seeds)", refine=False, retrieval=True,
    select_rollouts=30, select_candidates=4))
register_method(_residual_method(
    "paper_literal", "ablation: the residual moves translation and rotation only (Eq. 4 as written: no gripper "
    "residual, no hold)", retrieval=True, paper_literal=True, role="ablation"))
register_method(_residual_method(
    "action_space", "variant: the residual adds logits to the frozen prior's own heat-map (a lattice around its "
    "proposal) and rotation bins instead of moving its action (compare with no_refinement on validation seeds)",
    refine=False, retrieval=True, action_space=True, goal_extremities=False, **EARLIER_TRAINING))
register_method(_residual_method(
    "goal_extremities", "variant: the Manager also reads the goal's two extremities (each end's tip and direction, "
    "this arm's end first) beside its box, trained as before balanced_residual (compare with no_refinement on "
    "validation seeds)", refine=False, retrieval=True, goal_extremities=True, **EARLIER_TRAINING))
register_method(_residual_method(
    "balanced_residual", "variant: goal_extremities trained with the pose terms balanced (beta 0.01: 0.1 rad weighs "
    "as 1 cm), a cosine learning-rate decay and the best checkpoint picked by the gate's clipped errors (compare "
    "with no_refinement on validation seeds)", refine=False, retrieval=True, goal_extremities=True,
    schedule="cosine", beta=0.01, select_by="clipped_error", **EARLIER_QUATERNIONS))
register_method(_residual_method(
    "gripper_down_quaternions", "variant: balanced_residual with every quaternion the Manager reads on the "
    "gripper-down pose's side instead of w >= 0, whose sign flips at random near that pose (compare with "
    "balanced_residual on validation seeds)", refine=False, retrieval=True, goal_extremities=True,
    schedule="cosine", beta=0.01, select_by="clipped_error", quaternion_sign="gripper_down"))
register_method(_residual_method(
    "nearest_twin", "variant: the full method before refinement whose rotation residual is trained towards the "
    "expert's grasp or its twin half a turn about the gripper's axis (the same parallel grasp), whichever is nearer "
    "the prior's proposal (compare with no_refinement on validation seeds)", refine=False, retrieval=True,
    rotation_target="nearest_twin"))
register_method(_residual_method(
    "slot_twin", "variant: the full method before refinement whose rotation residual is trained towards the "
    "expert's grasp or its twin half a turn about the gripper's axis, whichever is nearer the training demos' mean "
    "grasp at the same arm and keyframe slot (compare with no_refinement on validation seeds)", refine=False,
    retrieval=True, rotation_target="slot_twin"))
register_method(_residual_method(
    "object_boxes", "variant: the full method before refinement whose Manager also reads each goal noun's own box "
    "(the tray's beside the oven's; the dirt's beside the dustpan's and the brush's) next to the union's box and "
    "extremities (compare with no_refinement on validation seeds)", refine=False, retrieval=True, goal_objects=True))
register_method(_residual_method(
    "start_goal", "variant: the full method before refinement whose Manager also reads, at every keyframe, the goal "
    "geometry of the episode's first keyframe (its union and each goal noun's box), where things lay before the "
    "arms moved or hid them (compare with no_refinement on validation seeds)", refine=False, retrieval=True,
    goal_at_start=True))
register_method(_residual_method(
    "augment_32", "variant: the full method before refinement trained on 32 augmented copies of every demo keyframe "
    "instead of 8 (more of the same shifts; compare with no_refinement on validation seeds)", refine=False,
    retrieval=True, augment_copies=32))
register_method(_residual_method(
    "augment_wide", "variant: the full method before refinement trained on augmented copies shifted by up to 10 cm "
    "instead of 4 (more scene layouts than the demos show; compare with no_refinement on validation seeds)",
    refine=False, retrieval=True, augment_translation_m=0.10))
register_method(_residual_method(
    "keyframe_gate", "variant: goal_extremities with the output gate's factors chosen per keyframe (compare with "
    "no_refinement and goal_extremities on validation seeds)", refine=False, retrieval=True, goal_extremities=True,
    gate_per_keyframe=True, **EARLIER_TRAINING))
register_method(_residual_method(
    "prompted_prior", "variant: the full method before refinement whose frozen prior is asked the instruction of its "
    "own suite whose proposals lie closest to the training demos' keyframes, when one beats the task's own phrasing "
    "by 25 % (--prior-instruction auto; compare with no_refinement on validation seeds)", refine=False,
    retrieval=True, prior_instruction="auto"))
register_method(_residual_method(
    "role_prompted_prior", "variant: the full method before refinement whose frozen prior is asked, per arm, the "
    "instruction of its own suite that a classifier picks from what the arm observes, fitted on the training demos' "
    "best-scoring instruction per arm (translation and rotation; --prior-instruction per_arm; compare with "
    "no_refinement on validation seeds)", refine=False, retrieval=True, prior_instruction="per_arm"))
register_method(_residual_method(
    "explicit_roles", "variant: the full method before refinement whose keyframe slots belong to (role, arm) pairs: "
    "the arm that moves first in a demo leads, and a classifier fitted on the demos decides which arm leads from "
    "what the arms see at an episode's first keyframe (--roles true, the default since it was measured: the same "
    "as no_refinement now; kept for its recorded rows)", refine=False, retrieval=True, roles=True))
register_method(_residual_method(
    "per_arm_slots", "variant: the full method before refinement whose keyframe slots belong to arm names (--roles "
    "false, the default before explicit roles; compare with no_refinement on validation seeds)", refine=False,
    retrieval=True))
register_method(_residual_method(
    "heading_anchor", "variant: the full method before refinement whose base orientation, at the keyframe slots "
    "where the training demos grasp at a fixed orientation relative to the goal's end direction, turns with that "
    "direction instead of being the prior's (residual/heading_anchor.py; compare with no_refinement on validation "
    "seeds)", refine=False, retrieval=True, heading_anchor=True))
for _width in (32, 64, 128):
    register_method(_residual_method(
        f"hidden_{_width}", f"variant: the full method before refinement with a Manager of {_width}-wide hidden "
        "layers instead of 256 (a lighter residual; compare with no_refinement on validation seeds)",
        refine=False, retrieval=True, hidden=_width))
register_method(_residual_method(
    "no_projection", "ablation: the prior sees the global scene", retrieval=True, use_projection=False,
    role="ablation"))
register_method(_frozen_prior_method(
    "no_residual", "ablation: the frozen prior per arm through the projection, no residual", use_projection=True,
    role="ablation"))
register_method(_residual_method(
    "no_retrieval", "ablation: no memory bank reference", retrieval=False, role="ablation"))
register_method(_residual_method(
    "unstructured", "ablation: an MLP residual with no skill basis", retrieval=True, structured=False,
    role="ablation"))
register_method(_frozen_prior_method(
    "frozen_prior_per_arm", "baseline: the frozen prior drives each arm on the global scene, nothing trained",
    use_projection=False, role="reference"))



def method_config(default: Any, overrides: dict[str, Any], method: str) -> Any:
    """The method's typed training config: its default with the request's ``overrides`` (field: value) applied;
    an unknown field or a value of the wrong type is named with the fields the method has."""
    names = {f.name: f for f in fields(default)}
    unknown = sorted(set(overrides) - set(names))
    if unknown:
        raise ValueError(f"method {method!r} has no training option(s) {unknown}; its options: {sorted(names)}")
    for key, value in overrides.items():
        expected = type(getattr(default, key))
        if expected is float and isinstance(value, int) and not isinstance(value, bool):
            continue
        if not isinstance(value, expected):
            raise ValueError(f"method {method!r}: training option {key}={value!r} should be a {expected.__name__}")
    return replace(default, **overrides)


def _backbone_method(name: str, description: str, trainer: str, policy: str, config: Any,
                     continual: bool = False, role: str = "baseline") -> MethodSpec:
    """A baseline that trains or fine-tunes a voxel backbone: ``trainer`` names a function of
    ``bimanualshift.training.baseline_trainers``, ``policy`` a class as "module:Class" under
    ``bimanualshift.methods.baselines``, ``config`` its default typed training config."""

    def train(request: TrainRequest) -> Path:
        from bimanualshift.training import baseline_trainers
        from bimanualshift.utils.io import atomic_write_json

        cfg = method_config(config, request.overrides, name)
        done = Path(request.out) / "done.json"
        if done.is_file():  # trained by an earlier (interrupted) benchmark run
            return Path(json.loads(done.read_text()))
        checkpoint = getattr(baseline_trainers, trainer)(request, cfg)
        atomic_write_json(done, str(checkpoint))
        return checkpoint

    def load(checkpoint: Path | None, request: TrainRequest) -> Policy:
        import importlib

        from bimanualshift.encoders.text import default_text_encoder

        module, cls = policy.split(":")
        return getattr(importlib.import_module(f"bimanualshift.methods.baselines.{module}"), cls)(
            checkpoint, default_text_encoder())

    return MethodSpec(name, description, train, load, continual, config=config, role=role)


_BACKBONE = BackboneTrainConfig()
register_method(_backbone_method(
    "scratch_voxel", "baseline: a PerAct2-style voxel policy for both arms trained from scratch on the bimanual demos "
    "(global scene, no prior, no residual)", "train_scratch_voxel", "from_scratch:ScratchVoxelPolicy", _BACKBONE,
    role="from_scratch"))
register_method(_backbone_method(
    "voxactb", "baseline: VoxAct-B-style, a voxel policy from scratch on a region of interest found from the goal "
    "masks (instead of a VLM), one network for the acting and the stabilising arm", "train_voxactb",
    # it trains from scratch too, but the targets' from-scratch group is the single-network PerAct2 / DP / ACT trio
    "voxactb:VoxActBPolicy", _BACKBONE))
register_method(_backbone_method(
    "peract_lf", "baseline: PerAct-LF, leader (right) and follower (left) networks fine-tuned from the single-arm "
    "prior on the bimanual demos; the follower conditions on the leader's action",
    "train_leader_follower", "leader_follower_tuned:LeaderFollowerPolicy", LeaderFollowerTrainConfig(),
    continual=True))
register_method(_backbone_method(
    "anybimanual", "baseline: AnyBimanual-style, the single-arm prior fine-tuned with learned soft voxel masks per arm "
    "and skill-weighted language", "train_anybimanual", "anybimanual:AnyBimanualPolicy", replace(_BACKBONE, lr=5e-4)))
register_method(_backbone_method(
    "dp_lf", "baseline: DP-LF, the leader-follower pair fine-tuned from the shipped Diffusion Policy prior "
    "(dp_suite_v2) on the bimanual demos", "train_leader_follower",
    "leader_follower_tuned:DiffusionLeaderFollowerPolicy",
    # the benchmark's --prior names the prior the other methods use; DP-LF fine-tunes the Diffusion Policy prior
    LeaderFollowerTrainConfig(lr=1e-4, optimizer="adamw", kind="diffusion", prior="dp_suite_v2"), continual=True))
register_method(_backbone_method(
    "rvt_lf", "baseline: RVT-LF, the leader-follower pair fine-tuned from the shipped RVT-style prior (rvt_suite) on "
    "the bimanual demos",
    "train_leader_follower", "leader_follower_tuned:RVTLeaderFollowerPolicy",
    LeaderFollowerTrainConfig(kind="rvt", prior="rvt_suite"), continual=True))
register_method(_backbone_method(
    "scratch_dp", "baseline: a Diffusion Policy for both arms (point cloud of the global scene, the other arm's pose "
    "and the acting arm's one-hot as extra proprioception) trained from scratch on the bimanual demos only",
    # AdamW as the shipped Diffusion Policy prior was pretrained with
    "train_scratch_dp", "from_scratch:ScratchDiffusionPolicy", replace(_BACKBONE, lr=3e-4, optimizer="adamw"),
    role="from_scratch"))
register_method(_backbone_method(
    "scratch_act", "baseline: ACT (a CVAE transformer predicting action chunks; point cloud of the global scene, the "
    "other arm's pose and the acting arm's one-hot as extra proprioception) trained from scratch on the bimanual demos",
    # AdamW at ACT's learning rate
    "train_scratch_act", "from_scratch:ScratchACTPolicy", replace(_BACKBONE, lr=1e-4, optimizer="adamw"),
    role="from_scratch"))
