"""Which instruction brings the frozen prior's proposals closest to the expert's keyframes? (writes
results/prior_instructions.json)

    .venv/bin/python benchmarks/investigations/prior_instructions.py --data data/bench/validation data/bench/train

Both arms ask the prior the bimanual instruction, and on take tray out of oven its proposals lie a median 30 cm
from the expert's keyframes. The prior's own suite holds the two halves of that task as single-arm skills ("open
the oven door", "take the tray out of the open oven"). Teacher-forced on the demos through the method's own
observation path (the arm-conditioned projection), this measures the prior's translation error on every bimanual
task when both arms are given the task's own phrasing or one of the instructions of the prior's pretraining suite.
On take tray it also splits the error by arm role (the door arm, and the tray arm, which holds still while the door
opens) and gives each role its own sub-instruction (which needs the role, so it bounds any per-arm choice).
Nothing is trained.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch

from bimanualshift.data.episode import list_episodes
from bimanualshift.encoders.text import default_text_encoder
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.methods.prior_step import FrozenPriorStep
from bimanualshift.perception.arm_samples import ArmSamples, build_arm_samples
from bimanualshift.priors import UnimanualPrior
from bimanualshift.sim.task_registry import resolve_task_names
from bimanualshift.training.prior_instruction import proposal_errors, suite_instructions
from bimanualshift.utils.pipes import quiet_on_closed_pipe

TRAY_TASK = "take_tray_out_of_oven"
DOOR, TRAY = "open the oven door", "take the tray out of the open oven"
# take tray's role schemes: name -> (door arm's instruction, tray arm's instruction)
ROLE_SCHEMES: dict[str, tuple[str, str]] = {"each role its skill": (DOOR, TRAY), "roles swapped": (TRAY, DOOR)}
OWN = "own phrasing"


def tray_arms(samples: ArmSamples) -> dict[int, str]:
    """Per episode, the arm that holds still while the door opens (its first two targets coincide)."""
    out = {}
    for e in np.unique(samples.episode):
        still = {}
        for arm in ("left", "right"):
            rows = np.flatnonzero((samples.episode == e) & (np.asarray(samples.arm) == arm))
            rows = rows[np.argsort(samples.keyframe[rows])]
            still[arm] = float(np.linalg.norm(samples.action_pos[rows[1]] - samples.action_pos[rows[0]]))
        out[int(e)] = min(still, key=still.get)
    return out


def error_rows(step: FrozenPriorStep, samples: ArmSamples, texts: list[str], groups: dict[str, np.ndarray],
               **labels: str) -> list[dict]:
    trans = proposal_errors(step, samples, texts)
    rows = []
    for group, mask in groups.items():
        first = mask & (samples.keyframe == 0)
        rows.append({**labels, "arms": group, "keyframes": int(mask.sum()),
                     "median_cm": round(100 * float(np.median(trans[mask])), 1),
                     "within_3cm": round(float(np.mean(trans[mask] < 0.03)), 3),
                     "first_keyframe_median_cm": round(100 * float(np.median(trans[first])), 1)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--prior", default="peract_suite_v2")
    parser.add_argument("--tasks", nargs="+", default=["bimanual"])
    parser.add_argument("--data", nargs="+", default=["data/bench/validation"],
                        help="demo folders (one sub-folder per task); each is reported on its own")
    parser.add_argument("--demos", type=int, default=0, help="the first N demos of each task (0: all)")
    parser.add_argument("--out", default="results/prior_instructions.json")
    args = parser.parse_args()
    torch.set_num_threads(2)
    started = time.time()
    model = UnimanualPrior.from_pretrained(args.prior).freeze()
    step = FrozenPriorStep(model, default_text_encoder())
    builder = step.builder
    candidates = suite_instructions(args.prior)
    rows, seeds = [], {}
    for folder in args.data:
        seeds[Path(folder).name] = []
        for task in resolve_task_names(args.tasks):
            paths = list_episodes(folder, task)[: args.demos or None]
            if not paths:
                sys.exit(f"no {task} demos under {folder}; collect them with "
                         f"`bimanualshift collect --task {task} --out {folder}`")
            seeds[Path(folder).name] += [int(p.stem.rsplit("_", 1)[1]) for p in paths]  # episode_<seed>.h5
            samples = build_arm_samples(paths, builder, model.config.max_keyframes, desc=f"voxelise {task}")
            groups = {"both": np.ones(len(samples), bool)}
            if task == TRAY_TASK:
                tray_arm = tray_arms(samples)
                is_tray = np.array([tray_arm[int(e)] == a for e, a in zip(samples.episode, samples.arm,
                                                                               strict=True)])
                groups |= {"door arm": ~is_tray, "tray arm": is_tray}
            labels = {"demos": folder, "task": task}
            for text in [OWN, *candidates]:
                texts = list(samples.instructions) if text == OWN else [text] * len(samples)
                rows += error_rows(step, samples, texts, groups, **labels, instruction=text)
            if task == TRAY_TASK:
                for scheme, (door_text, tray_text) in ROLE_SCHEMES.items():
                    texts = [tray_text if t else door_text for t in is_tray]
                    rows += error_rows(step, samples, texts, groups, **labels, instruction=scheme)
            best = min((r for r in rows if r["task"] == task and r["demos"] == folder and r["arms"] == "both"),
                       key=lambda r: r["median_cm"])
            own = next(r for r in rows if r["task"] == task and r["demos"] == folder and r["arms"] == "both"
                       and r["instruction"] == OWN)
            print(f"{folder} {task}: own phrasing {own['median_cm']} cm; best {best['instruction']!r} "
                  f"{best['median_cm']} cm")
    for folder in seeds:
        seeds[folder].sort()
    command = invoked_command()
    notes = ("teacher-forced translation error of the frozen prior's first proposed action, through the "
             "arm-conditioned projection, both arms given the same instruction (take tray's role schemes give each "
             "role its own, the role read from the expert, so they bound any per-arm choice)")
    print(f"wrote {write_result(args.out, command, seeds, started, rows, notes=notes, prior=args.prior)}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
