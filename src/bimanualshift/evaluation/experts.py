"""Rows of the scripted experts' check (`bimanualshift experts`, results/experts.json)."""

from __future__ import annotations

from typing import Any

import numpy as np

from bimanualshift.evaluation.stats import SuccessRate, SuccessRow
from bimanualshift.sim.expert_check import ExpertEpisode


def expert_rows(tasks: list[str], episodes: list[ExpertEpisode]) -> list[dict[str, Any]]:
    from bimanualshift.sim.task import TASKS

    rows = []
    for task in tasks:
        mine = [e for e in episodes if e.task == task]
        rows.append(SuccessRow(task, "scripted_expert", SuccessRate.of(e.success for e in mine),
                               context={"bimanual": TASKS[task].bimanual},
                               details={"mean_wall_time_s": round(float(np.mean([e.wall_time_s for e in mine])), 2),
                                        "mean_keyframes": round(float(np.mean([e.keyframes for e in mine])), 2),
                                        "failed_seeds": [e.seed for e in mine if not e.success]}).to_dict())
    return rows
