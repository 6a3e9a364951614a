"""The instruction the frozen prior is asked with, chosen on the training demos (``--prior-instruction auto``).

The paper asks the single-arm prior with the bimanual instruction. Where the prior never saw that task, its
proposals can lie far from every keyframe (take tray out of oven: a median 30 cm) while one of its own skills
("open the oven door") lands near one arm's (results/prior_instructions.json). ``auto`` asks the frozen prior,
teacher-forced on the training demos, with the task's own phrasing and with each instruction of its pretraining
suite, and keeps the instruction whose proposals lie closest to the expert's keyframes, if it beats the task's own
phrasing by a clear margin. The Manager and the memory keep reading the task's instruction; only the prior's
text input changes. One choice per run: a residual trained on one task.

``per_arm`` chooses per arm instead: the suite instruction whose proposals most improve on the task's own phrasing
over the training demos' arms (translation and rotation, each clipped as the output gate clips them) is given to
each demo's arm where it beats the own phrasing by the margin, and an ``InstructionChooser`` learns to pick it from
what the arm observes, so an arm's skill follows its role in the scene (take tray: the door arm is asked "open the
oven door", the tray arm the task's own words).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from tqdm import tqdm

from bimanualshift.methods.instruction_chooser import OWN_PHRASING, InstructionChooser, chooser_features
from bimanualshift.methods.prior_step import FrozenPriorStep
from bimanualshift.perception.arm_samples import ArmSamples
from bimanualshift.priors.base import resolve_prior_path
from bimanualshift.residual.output_gate import ROTATION_CLIP_RAD, TRANSLATION_CLIP_M
from bimanualshift.training.keyframe_errors import keyframe_errors
from bimanualshift.training.pretrain import PriorBatches
from bimanualshift.utils.config_files import read_json_file

AUTO = "auto"
PER_ARM = "per_arm"
# A suite instruction replaces the task's own phrasing only when its median keyframe error is this much lower
# (relative): smaller gaps on a few demos are noise, and the task's own words are what a user wrote.
MARGIN = 0.25
# Demos the choice is made on (the first ones): each candidate costs one prior pass per keyframe and arm, ~7 min for
# twelve candidates on 30 demos on two CPU cores; take tray's and sweep's choices stand out on 5 (the margins in
# results/prior_instructions.json are 2-3x).
CHOICE_DEMOS = 10
# ``per_arm`` fits a classifier on the choice's labels: it reads role cues better from more scenes (take tray's
# roles: 87 % from 30 scenes' first keyframes, 94 % from 300; results/role_cues.json).
PER_ARM_CHOICE_DEMOS = 30
CV_FOLDS = 5  # the chooser's accuracy is reported held out over folds of demos


def suite_instructions(prior: str) -> list[str]:
    """One instruction per task the prior was pretrained on (its config's ``pretrain_tasks``), as that task's
    first scene phrases it; empty for a prior that does not record its tasks or names one this version lacks."""
    from bimanualshift.sim.env import ManipulationEnv
    from bimanualshift.sim.task_registry import task_names

    recorded = read_json_file(resolve_prior_path(prior) / "config.json", "prior's config").get("pretrain_tasks")
    known = set(task_names())
    out = []
    for task in recorded or []:
        if task not in known:
            continue
        env = ManipulationEnv(task)
        try:
            out.append(env.reset(seed=0, options={"render": False, "settle": False})[1]["instruction"])
        finally:
            env.close()
    return list(dict.fromkeys(out))


def teacher_forced_errors(prior_step: FrozenPriorStep, samples: ArmSamples, texts: list[str]
                          ) -> tuple[np.ndarray, np.ndarray]:
    """(N,) the prior's teacher-forced translation (m) and rotation (degrees) errors on each (keyframe, arm) of
    ``samples``, each asked its own entry of ``texts``."""
    prior = prior_step.prior
    batches = PriorBatches(dataclasses.replace(samples, instructions=texts), prior_step.builder.grid,
                           prior.action_horizon)
    trans, rot, _ = keyframe_errors(prior, batches)
    return trans, rot


def proposal_errors(prior_step: FrozenPriorStep, samples: ArmSamples, texts: list[str]) -> np.ndarray:
    """(N,) the prior's teacher-forced translation error (m) on each (keyframe, arm) of ``samples``, each asked
    its own entry of ``texts``."""
    return teacher_forced_errors(prior_step, samples, texts)[0]


def clipped_scores(trans_m: np.ndarray, rot_deg: np.ndarray) -> np.ndarray:
    """Per sample, the translation error clipped at the output gate's clip over that clip plus the rotation error
    likewise (each in [0, 1]): a proposal 40 cm off is as useless as one 5 cm off, and a right place at the wrong
    turn misses a grasp."""
    return (np.minimum(trans_m, TRANSLATION_CLIP_M) / TRANSLATION_CLIP_M
            + np.minimum(np.deg2rad(rot_deg), ROTATION_CLIP_RAD) / ROTATION_CLIP_RAD)


def median_errors(prior_step: FrozenPriorStep, samples: ArmSamples, instructions: list[str]) -> list[float]:
    """Per instruction (``OWN_PHRASING``: each sample's own), the prior's median teacher-forced translation
    error (m) over every (keyframe, arm) of ``samples``."""
    out = []
    for text in tqdm(instructions, desc="ask the prior each instruction", unit="instruction"):
        texts = list(samples.instructions) if text == OWN_PHRASING else [text] * len(samples)
        out.append(float(np.median(proposal_errors(prior_step, samples, texts))))
    return out


def choose_prior_instruction(prior_step: FrozenPriorStep, samples: ArmSamples, candidates: list[str],
                             margin: float = MARGIN) -> tuple[str, list[dict[str, Any]]]:
    """The instruction for the prior (``OWN_PHRASING`` when none beats the task's own by ``margin``) and the
    table it was chosen from (instruction, median error in cm)."""
    texts = [OWN_PHRASING, *[c for c in candidates if c]]
    errors = median_errors(prior_step, samples, texts)
    table = [{"instruction": t or "(the task's own)", "median_cm": round(100 * e, 2)}
             for t, e in zip(texts, errors, strict=True)]
    best = int(np.argmin(errors))
    chosen = texts[best] if errors[best] < (1 - margin) * errors[0] else OWN_PHRASING
    return chosen, table


def sample_features(samples: ArmSamples) -> np.ndarray:
    """(N, F) the chooser's features of every (keyframe, arm) of ``samples``."""
    goal = samples.goal if samples.goal is not None else np.zeros((len(samples), 0))
    return chooser_features(goal, samples.proprio, samples.other_proprio)


def arm_labels(scores: dict[str, np.ndarray], samples: ArmSamples, margin: float = MARGIN) -> list[str]:
    """Per sample, the instruction its (demo, arm) is asked: one instruction besides the task's own phrasing
    (``scores[OWN_PHRASING]``), the one that lowers the arms' mean ``clipped_scores`` the most summed over the
    (demo, arm)s where it beats the own phrasing by ``margin``, for those (demo, arm)s; the own phrasing elsewhere.
    One instruction, not each arm's best: near-synonyms ("hold the dustpan by its handle", "drag the dustpan onto the
    target") would split one role into classes no observation tells apart."""
    arms = np.asarray(samples.arm)
    groups = [np.flatnonzero((samples.episode == e) & (arms == a)) for e in np.unique(samples.episode)
              for a in np.unique(arms)]
    groups = [rows for rows in groups if len(rows)]
    own = np.array([scores[OWN_PHRASING][rows].mean() for rows in groups])
    best, best_gain, best_wins = OWN_PHRASING, 0.0, np.zeros(len(groups), bool)
    for text, score in scores.items():
        if text == OWN_PHRASING:
            continue
        means = np.array([score[rows].mean() for rows in groups])
        wins = means < (1 - margin) * own
        gain = float((own - means)[wins].sum())
        if gain > best_gain:
            best, best_gain, best_wins = text, gain, wins
    labels = [OWN_PHRASING] * len(samples)
    for r in np.concatenate([rows for rows, win in zip(groups, best_wins, strict=True) if win] or [[]]):
        labels[int(r)] = best
    return labels


def held_out_accuracy(features: np.ndarray, labels: list[str], episodes: np.ndarray, folds: int = CV_FOLDS
                      ) -> float | None:
    """The chooser's accuracy on samples of demos it was not fitted on, over ``folds`` folds of demos (None with
    fewer than two demos)."""
    demos = np.unique(episodes)
    if len(demos) < 2:
        return None
    right = 0
    for held in np.array_split(demos, min(folds, len(demos))):
        test = np.isin(episodes, held)
        chooser = InstructionChooser.fit(features[~test], [lb for lb, t in zip(labels, test, strict=True) if not t])
        chosen = chooser.choose(features[test])
        right += sum(c == lb for c, lb in zip(chosen, [lb for lb, t in zip(labels, test, strict=True) if t],
                                              strict=True))
    return right / len(labels)


def choose_arm_instructions(prior_step: FrozenPriorStep, samples: ArmSamples, candidates: list[str],
                            margin: float = MARGIN) -> tuple[InstructionChooser | None, dict[str, Any]]:
    """The per-arm chooser (None when every arm of every demo keeps the task's own phrasing) and its record: each
    candidate's mean clipped score, the labels' counts and the chooser's held-out accuracy."""
    texts = [OWN_PHRASING, *[c for c in candidates if c]]
    scores = {}
    for text in tqdm(texts, desc="ask the prior each instruction", unit="instruction"):
        asked = list(samples.instructions) if text == OWN_PHRASING else [text] * len(samples)
        scores[text] = clipped_scores(*teacher_forced_errors(prior_step, samples, asked))
    labels = arm_labels(scores, samples, margin)
    features = sample_features(samples)
    counts = {text or "(the task's own)": labels.count(text) for text in dict.fromkeys(labels)}
    record: dict[str, Any] = {
        "candidates": [{"instruction": t or "(the task's own)", "mean_clipped_score": round(float(s.mean()), 4)}
                       for t, s in scores.items()],
        "label_samples": counts}
    if set(labels) == {OWN_PHRASING}:
        return None, record
    chooser = InstructionChooser.fit(features, labels)
    chosen = chooser.choose(features)
    record["train_accuracy"] = round(float(np.mean([c == lb for c, lb in zip(chosen, labels, strict=True)])), 4)
    accuracy = held_out_accuracy(features, labels, samples.episode)
    record["held_out_accuracy"] = None if accuracy is None else round(accuracy, 4)
    return chooser, record
