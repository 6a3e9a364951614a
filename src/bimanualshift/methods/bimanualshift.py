"""BimanualShift: frozen prior per arm (through the arm-conditioned projection) + residual G(v) (Eq. 4)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import torch

from bimanualshift.core.threads import policy_threads
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.encoders.text import DEFAULT_SPEC, TextEncoder, default_text_encoder, make_text_encoder
from bimanualshift.geometry.frames import compose_rotation, euler_bins_to_quat
from bimanualshift.memory.bank import MemoryBank, Retrieval
from bimanualshift.memory.reference import ProgressAlignment, episode_key, reference_vector
from bimanualshift.methods.instruction_chooser import InstructionChooser
from bimanualshift.methods.prior_step import ArmStep, FrozenPriorStep, goal_switches, world_action
from bimanualshift.methods.role_assigner import RoleAssigner, role_features
from bimanualshift.priors.base import UnimanualPrior
from bimanualshift.residual.checkpoint import (
    load_residual_checkpoint,
    read_residual_config,
    save_residual_checkpoint,
)
from bimanualshift.residual.heading_anchor import anchored_base
from bimanualshift.residual.manager import ResidualPolicy, action_lattice, manager_input_rows, phase_one_hot
from bimanualshift.utils.hub import resolve_local

MEMORY_FILE = "memory.safetensors"  # the frozen memory bank, beside the residual's weights
BUNDLED_PRIOR = "prior"  # a checkpoint shared on the hub carries a prior that is neither shipped nor on the hub


def checkpoint_prior(directory: Path, prior: str) -> str | Path:
    """The prior a checkpoint names: a copy bundled inside the checkpoint (``prior/``, as `bimanualshift push`
    writes it) before a name, hub reference or path read as given."""
    bundled = directory / prior
    if prior == BUNDLED_PRIOR and (bundled / "config.json").is_file():
        return bundled
    return prior


class BimanualShift:
    name = "bimanualshift"

    def __init__(self, prior_step: FrozenPriorStep, residual: ResidualPolicy, memory: MemoryBank | None = None,
                 text_encoder: TextEncoder | None = None, role_assigner: RoleAssigner | None = None) -> None:
        if (memory is not None) != (residual.config.reference_dim > 0):
            raise ValueError("a residual trained with retrieval needs its memory bank, and one trained without "
                             "retrieval takes none")
        self.prior_step = prior_step
        self.text_encoder = text_encoder or prior_step.text_encoder  # the residual's; the prior keeps its own
        if self.text_encoder.dim != residual.config.text_dim:
            raise ValueError(f"the residual reads {residual.config.text_dim}-wide instruction embeddings, the text "
                             f"encoder gives {self.text_encoder.dim}: load it with the encoder it was trained with")
        self.residual = residual.eval()
        if residual.config.role_phase and role_assigner is None:
            raise ValueError("a residual trained with --roles true needs its role assigner (the checkpoint's "
                             "config.json 'role_assigner')")
        self.role_assigner = role_assigner if residual.config.role_phase else None
        self._roles: dict[str, int] = {}  # per arm, its role in this episode (decided at the first keyframe)
        self.memory = memory.freeze() if memory is not None else None
        self.retrieval: Retrieval | None = None
        self._retrieved = False
        self._key: np.ndarray | None = None
        self._last_action: dict[str, np.ndarray] = {}  # per arm, what a hold repeats
        self._nearest_similarity: float | None = None
        self._log: list[dict] = []
        self.alignment: ProgressAlignment | None = None  # each arm's step in the retrieved execution
        self._steps: dict[str, int] = {}
        self._start_goal: dict[str, np.ndarray] = {}  # per arm, the goal geometry of the episode's first keyframe

    def reset(self) -> None:
        self.retrieval, self._retrieved, self._key = None, False, None
        self._last_action, self._nearest_similarity, self._log = {}, None, []
        self.alignment, self._steps, self._start_goal = None, {}, {}
        self._roles = {}

    def _retrieve(self, steps: dict, text: torch.Tensor, arms: list[str]) -> None:
        """Once per episode, on its first observation: the most similar stored execution, if confident."""
        if self.memory is not None and not self._retrieved:
            self._key = episode_key(text[0].numpy(), [steps[a].prior.features[0].numpy() for a in arms])
            nearest = self.memory.nearest(self._key)
            self._nearest_similarity = None if nearest is None else nearest.similarity
            self.retrieval = nearest if nearest is not None and nearest.similarity >= self.memory.threshold else None
            self.alignment = ProgressAlignment(self.retrieval.trajectory) if self.retrieval is not None else None
            self._retrieved = True

    def keyframe_log(self) -> dict:
        """The last keyframe's decisions, per arm: the frozen prior's world-frame action (position, quaternion,
        open probability), the final action, the gripper's open probability after the residual and whether the
        arm held; and the episode's retrieval: the nearest stored execution's similarity, whether it passed
        the threshold (fired), and the fired entry's index, source ("demo" or "refinement") and seed."""
        return {"arms": self._log, "retrieval": None if self.memory is None else {
            "similarity": self._nearest_similarity, "fired": self.retrieval is not None,
            "entry": None if self.retrieval is None else self.retrieval.index,
            "source": None if self.retrieval is None else self.retrieval.entry.source,
            "source_seed": None if self.retrieval is None else self.retrieval.entry.seed,
            "aligned_step": dict(self._steps)}}

    @torch.no_grad()
    def decide(self, obs: KeyframeObservation) -> list[ArmDecision]:
        """Each arm's Manager input, frozen-prior action and final action (Eq. 4) at this keyframe."""
        with policy_threads():  # the same bits from any caller, whatever its thread count (core/threads.py)
            return self._decide(obs)

    def _decide(self, obs: KeyframeObservation) -> list[ArmDecision]:
        steps = self.prior_step.run(obs)
        text = torch.as_tensor(self.text_encoder.encode([obs.instruction]))
        arms = obs.scene.arm_names
        self._retrieve(steps, text, arms)
        if self.role_assigner is not None and not self._roles:  # once per episode, from its first observation
            features = np.concatenate([role_features(steps[a].goal, steps[a].proprio, steps[a].other_proprio, [i])
                                       for i, a in enumerate(arms)])
            self._roles = dict(zip(arms, (int(r) for r in self.role_assigner.assign(features)), strict=True))
        decisions = []
        for i, arm in enumerate(arms):
            s = self._anchored(steps[arm], i, obs.keyframe_index, self._roles.get(arm))
            reference = None
            if self.memory is not None:
                step = self.alignment.step_of(i, s.proprio[:3], float(s.proprio[7])) if self.alignment else 0
                self._steps[arm] = step
                reference = torch.as_tensor(reference_vector(self.retrieval, step, i,
                                                             s.prior.base_action()[0].numpy()))[None]
            goal = torch.as_tensor(s.goal)[None] if self.residual.config.goal_dim else None
            start_goal = torch.as_tensor(self._start_goal.setdefault(arm, s.goal))[None]  # set at the first keyframe
            inputs = manager_input_rows(
                self.residual.config, s.prior.features, torch.as_tensor(s.proprio)[None],
                torch.as_tensor(s.other_proprio)[None], text, s.prior.base_action(), torch.tensor([i]),
                torch.tensor([obs.keyframe_index]), reference, goal, s.prior.proposal_features, start_goal,
                torch.tensor([self._roles[arm]]) if self._roles else None,
            )
            out = self.residual(inputs)
            action, held = self.final_action(arm, s, out)
            self._last_action[arm] = action
            decisions.append(ArmDecision(arm, s, inputs[0], action, held))
        self._log = [decision_log(d) for d in decisions]
        if self._roles:
            for entry in self._log:
                entry["role"] = self._roles[entry["arm"]]
        return decisions

    def _anchored(self, step: ArmStep, arm_index: int, keyframe: int, role: int | None) -> ArmStep:
        """The arm's step with the heading anchor's orientation as the prior's where its slot is anchored
        (residual/heading_anchor.py): the Manager, the residual, the memory and refinement's targets all see it."""
        config = self.residual.config
        if not config.heading_anchor:
            return step
        phase = phase_one_hot(config, torch.tensor([keyframe]), torch.tensor([arm_index]),
                              None if role is None else torch.tensor([role]))
        base = anchored_base(config.heading_anchors, phase, torch.as_tensor(step.goal)[None], step.prior.base_action())
        return replace(step, prior=replace(step.prior, quat=base[:, 3:7]))

    def final_action(self, arm: str, step: ArmStep, out: dict[str, torch.Tensor]) -> tuple[np.ndarray, bool]:
        """The world-frame action of one arm from the prior's and the residual's outputs, and whether the arm holds.

        Eq. 4 moves the prior's position and orientation; a gripper residual moves its open/close logit; a hold
        repeats the arm's last action (at an episode's first keyframe, its current pose and gripper)."""
        prior = step.prior
        if "hold_logit" in out and float(out["hold_logit"][0]) > 0:
            last = self._last_action.get(arm)
            if last is None:
                own = step.proprio
                last = world_action(step.frame, own[:3], own[3:7], float(own[7]), float(prior.ignore_collisions[0]))
            return last.copy(), True
        if "translation_logits" in out:
            position, quat = self.action_space_pose(step, out)
        else:
            position = prior.position[0].numpy() + out["translation"][0].numpy()
            quat = compose_rotation(prior.quat[0].numpy(), out["rotation"][0].numpy())
        gripper = (float(torch.sigmoid(out["gripper_logit"][0])) if "gripper_logit" in out
                   else float(prior.gripper_open[0]))
        return world_action(step.frame, position, quat, gripper, float(prior.ignore_collisions[0])), False

    def action_space_pose(self, step: ArmStep, out: dict[str, torch.Tensor]) -> tuple[np.ndarray, np.ndarray]:
        """The action-space residual's pose: the arg-max of the prior's translation log-probabilities on the lattice
        around its proposal plus the residual's logits (the centre cell is the proposal itself, sub-voxel
        refinement included), and per Euler axis of its rotation bins' log-probabilities plus the residual's."""
        prior, model = step.prior, self.prior_step.prior
        cells = action_lattice(self.residual.config)
        scores = model.translation_scores(prior, prior.position[:, None] + cells[None])[0]
        chosen = int((scores + out["translation_logits"][0]).argmax())
        position = prior.position[0].numpy() + cells[chosen].numpy()
        logp = torch.log_softmax(prior.logits["rotation"][0].float(), -1)
        bins = (logp + out["rotation_logits"][0]).argmax(-1)
        if torch.equal(bins, logp.argmax(-1)):
            return position, prior.quat[0].numpy()
        return position, euler_bins_to_quat(bins.numpy(), model.rotation_bin_degrees).astype(np.float32)

    def act(self, obs: KeyframeObservation) -> np.ndarray:
        return np.stack([d.action for d in self.decide(obs)])

    def first_key(self) -> np.ndarray | None:
        """The memory key of the current episode (set by its first ``decide``), None without retrieval."""
        return self._key


@dataclass
class ArmDecision:
    arm: str
    step: ArmStep  # the arm's frame, proprioception and the frozen prior's output
    inputs: torch.Tensor  # the Manager's input row
    action: np.ndarray  # (9,) the world-frame action sent to the env
    held: bool = False  # the residual's hold kept this arm where its last action put it


def prior_world_action(step: ArmStep) -> np.ndarray:
    """The frozen prior's own action for one arm as a world-frame row (what the arm would do without residual)."""
    p = step.prior
    return world_action(step.frame, p.position[0].numpy(), p.quat[0].numpy(), float(p.gripper_open[0]),
                        float(p.ignore_collisions[0]))


def decision_log(d: ArmDecision) -> dict:
    """One arm's keyframe log entry (plain JSON values)."""
    prior = prior_world_action(d.step)
    log = {"arm": d.arm, "prior": np.round(prior[:7], 4).tolist(),
           "prior_gripper_open": round(float(d.step.prior.gripper_open[0]), 4),
           "final": np.round(d.action[:7], 4).tolist(), "gripper": float(d.action[7]), "held": d.held,
           "residual_cm": round(100 * float(np.linalg.norm(d.action[:3] - prior[:3])), 2)}
    if d.step.asked:  # the prior was asked another instruction (--prior-instruction): which one, per arm
        log["prior_asked"] = d.step.asked
    return log


def save_residual(directory: str | Path, residual: ResidualPolicy, extra: dict[str, Any],
                  memory: MemoryBank | None = None) -> Path:
    """The residual's checkpoint (``residual.checkpoint``) with the memory bank beside it."""
    if memory is not None:
        Path(directory).mkdir(parents=True, exist_ok=True)
        memory.save(Path(directory) / MEMORY_FILE)
    return save_residual_checkpoint(directory, residual, extra)


def load_bimanualshift(directory: str | Path, text_encoder: TextEncoder | None = None,
                       segmenter: str | None = None) -> BimanualShift:
    """A trained (or refined) BimanualShift; ``text_encoder`` is the prior's (default: the bundled MiniLM it is
    pretrained with), the residual's comes from the checkpoint's ``text_encoder`` spec. ``segmenter`` replaces
    the one it was trained with (a real robot has no simulator maps: ``grounded_sam``)."""
    directory = resolve_local(directory)
    cfg, rcfg = read_residual_config(directory)
    prior = UnimanualPrior.from_pretrained(checkpoint_prior(directory, cfg["prior"]))
    text_encoder = text_encoder or default_text_encoder()
    spec = cfg.get("text_encoder", DEFAULT_SPEC)
    # Older checkpoints recorded the bundled model's folder instead of a spec.
    residual_encoder = make_text_encoder(spec) if spec.partition(":")[0] in ("minilm", "clip", "st") else text_encoder
    _, residual = load_residual_checkpoint(directory, residual_encoder.dim)
    memory = MemoryBank.load(directory / MEMORY_FILE) if rcfg.reference_dim > 0 else None
    prior_step = FrozenPriorStep(prior, text_encoder, use_projection=cfg.get("use_projection", True),
                             **goal_switches(rcfg.goal_dim, rcfg.start_goal_dim),
                             segmenter=segmenter or cfg.get("segmenter", "simulator"),
                             segmenter_options=cfg.get("segmenter_options"),
                             proposal_features=rcfg.proposal_dim > 0,
                             prior_instruction=cfg.get("prior_instruction", ""),
                             instruction_chooser=(InstructionChooser.from_dict(cfg["instruction_chooser"])
                                                  if cfg.get("instruction_chooser") else None))
    assigner = RoleAssigner.from_dict(cfg["role_assigner"]) if cfg.get("role_assigner") else None
    return BimanualShift(prior_step, residual, memory, residual_encoder, assigner)
