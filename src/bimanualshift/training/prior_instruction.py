"""The instruction the frozen prior is asked with, chosen on the training demos (``--prior-instruction auto``).

The paper asks the single-arm prior with the bimanual instruction. Where the prior never saw that task, its
proposals can lie far from every keyframe (take tray out of oven: a median 30 cm) while one of its own skills
("open the oven door") lands near one arm's (results/prior_instructions.json). ``auto`` asks the frozen prior,
teacher-forced on the training demos, with the task's own phrasing and with each instruction of its pretraining
suite, and keeps the instruction whose proposals lie closest to the expert's keyframes, if it beats the task's own
phrasing by a clear margin. The Manager and the memory keep reading the task's instruction; only the prior's
text input changes. One choice per run: a residual trained on one task.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from tqdm import tqdm

from bimanualshift.methods.prior_step import FrozenPriorStep
from bimanualshift.perception.arm_samples import ArmSamples
from bimanualshift.priors.base import resolve_prior_path
from bimanualshift.training.keyframe_errors import keyframe_errors
from bimanualshift.training.pretrain import PriorBatches
from bimanualshift.utils.config_files import read_json_file

AUTO = "auto"
OWN_PHRASING = ""  # the prior reads each episode's own instruction (the paper)
# A suite instruction replaces the task's own phrasing only when its median keyframe error is this much lower
# (relative): smaller gaps on a few demos are noise, and the task's own words are what a user wrote.
MARGIN = 0.25
# Demos the choice is made on (the first ones): each candidate costs one prior pass per keyframe and arm, ~7 min for
# twelve candidates on 30 demos on two CPU cores; take tray's and sweep's choices stand out on 5 (the margins in
# results/prior_instructions.json are 2-3x).
CHOICE_DEMOS = 10


def suite_instructions(prior: str) -> list[str]:
    """One instruction per task the prior was pretrained on (its config's ``pretrain_tasks``), as that task's
    first scene phrases it; empty for a prior that does not record its tasks or names one this version lacks."""
    from bimanualshift.sim.env import ManipulationEnv
    from bimanualshift.sim.task import task_names

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


def proposal_errors(prior_step: FrozenPriorStep, samples: ArmSamples, texts: list[str]) -> np.ndarray:
    """(N,) the prior's teacher-forced translation error (m) on each (keyframe, arm) of ``samples``, each asked
    its own entry of ``texts``."""
    prior = prior_step.prior
    batches = PriorBatches(dataclasses.replace(samples, instructions=texts), prior_step.builder.grid,
                           prior.action_horizon)
    return keyframe_errors(prior, batches)[0]


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
