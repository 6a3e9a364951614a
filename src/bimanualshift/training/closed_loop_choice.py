"""Closed-loop checkpoint choice (`train --select-rollouts N`): while the residual trains, the checkpoint with the
lowest teacher-forced validation value in each of K equal stretches of the run is kept as a candidate; afterwards
each is rolled out on N validation scenes and the one that succeeds most becomes the run's ``best/``.

A teacher-forced error scores each keyframe from the demo's own state; a rollout scores the whole episode from the
policy's own states, where one early miss ends it. The two can disagree (a training seed's lift ball ranged 27-93 %
at a similar teacher-forced error), so the candidates are compared where the policy is used.

The scenes are validation-split seeds from ``SELECTION_ROLLOUT_START``: past the validation demos' and the
refinement's validation scenes, and apart from the benchmark's validation rollouts (``VALIDATION_ROLLOUT_START``),
so that a benchmark measuring what the choice buys does not score it on the scenes it chose with.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bimanualshift.data.seeds import split_seeds
from bimanualshift.utils.config_files import read_json_file
from bimanualshift.utils.io import atomic_write_json

SELECTION_ROLLOUT_START = 20_000
CANDIDATES_FOLDER = "candidates"  # under the run folder: step_NNNNNN/ per kept checkpoint
ROLLOUTS_FILE = "rollouts.json"  # in a candidate's folder: its episodes, so an interrupted choice resumes


def selection_seeds(episodes: int) -> list[int]:
    return split_seeds("validation", episodes, SELECTION_ROLLOUT_START)


def _value_and_step(folder: Path) -> tuple[float, int]:
    config = read_json_file(folder / "config.json")
    return float(config["validation_loss"]), int(config["trained_steps"])


def candidate_folders(run: Path) -> list[Path]:
    """The kept candidates, best teacher-forced value first (then the earlier step)."""
    root = run / CANDIDATES_FOLDER
    folders = [f for f in sorted(root.glob("step_*")) if (f / "config.json").is_file()] if root.is_dir() else []
    return sorted(folders, key=_value_and_step)


def segment(step: int, total_steps: int, parts: int) -> int:
    """Which of ``parts`` equal stretches of a ``total_steps`` run ``step`` falls in (step 0 in the first)."""
    return min(parts - 1, step * parts // max(total_steps, 1))


def keep_candidate(run: Path, step: int, value: float, parts: int, total_steps: int,
                   save: Callable[[Path], None]) -> bool:
    """Keep the checkpoint of ``step`` (``save(folder)``) when its validation ``value`` is the lowest so far of its
    stretch of the run (one of ``parts`` equal stretches), dropping the one it displaces; returns whether it was
    kept. One candidate per stretch, not the ``parts`` lowest values: on a decaying learning rate those are the last
    few checkpoints, nearly one set of weights, and rolling them all out would buy no choice."""
    mine = segment(step, total_steps, parts)
    rivals = {f: _value_and_step(f) for f in candidate_folders(run)}
    rivals = {f: v for f, (v, s) in rivals.items() if segment(s, total_steps, parts) == mine}
    if any(v <= value for v in rivals.values()):
        return False
    save(run / CANDIDATES_FOLDER / f"step_{step:06d}")
    for dropped in rivals:
        shutil.rmtree(dropped)
    return True


# A worker process keeps the policy and environment of its last job's candidate.
_WORKER: dict[str, Any] = {}


def selection_episode(job: tuple[str, str, int, int]) -> dict[str, Any]:
    """A worker's job: (candidate folder, task, seed, keyframe limit or 0 for the task's) -> the episode's outcome."""
    from bimanualshift.methods.bimanualshift import load_bimanualshift
    from bimanualshift.rollout.loop import rollout
    from bimanualshift.sim.env import ManipulationEnv

    folder, task, seed, max_keyframes = job
    if _WORKER.get("folder") != folder:
        _WORKER["policy"] = load_bimanualshift(Path(folder))
        _WORKER["folder"] = folder
    if _WORKER.get("task") != task:
        if "env" in _WORKER:
            _WORKER["env"].close()
        _WORKER["env"], _WORKER["task"] = ManipulationEnv(task), task
    env = _WORKER["env"]
    record = rollout(env, _WORKER["policy"], seed, max_keyframes or env.task.max_keyframes)
    return {"candidate": folder, "seed": seed, "success": bool(record.success),
            "stages_done": int(record.stages_done), "keyframes": int(record.keyframes)}


def roll_out_candidates(folders: list[Path], task: str, episodes: int, workers: int = 1,
                        max_keyframes: int = 0) -> list[dict[str, Any]]:
    """Each candidate's outcome on the selection scenes (read from its ``rollouts.json`` when done already)."""
    from bimanualshift.utils.workers import run_jobs

    seeds = selection_seeds(episodes)
    done: dict[str, list[dict[str, Any]]] = {}
    for folder in folders:
        saved = read_json_file(folder / ROLLOUTS_FILE) if (folder / ROLLOUTS_FILE).is_file() else {}
        if saved.get("seeds") == seeds and saved.get("max_keyframes", 0) == max_keyframes:
            done[str(folder)] = saved["episodes"]  # outcomes of other scenes or another limit are run again
    jobs = [(str(f), task, seed, max_keyframes) for f in folders if str(f) not in done for seed in seeds]
    if jobs:
        results = run_jobs(selection_episode, jobs, workers=min(workers, len(jobs)), desc="closed-loop choice",
                           chunksize=max(1, len(seeds) // max(workers, 1)))
        for folder in folders:
            mine = sorted((r for r in results if r["candidate"] == str(folder)), key=lambda r: r["seed"])
            if mine:
                episodes_of = [{k: v for k, v in r.items() if k != "candidate"} for r in mine]
                atomic_write_json(folder / ROLLOUTS_FILE, {"task": task, "seeds": seeds, "max_keyframes": max_keyframes,
                                                           "episodes": episodes_of})
                done[str(folder)] = episodes_of
    rows = []
    for folder in folders:
        value, step = _value_and_step(folder)
        outcomes = done[str(folder)]
        rows.append({"step": step, "validation_loss": value,
                     "successes": sum(e["success"] for e in outcomes), "episodes": len(outcomes),
                     "stages_done": sum(e["stages_done"] for e in outcomes)})
    return rows


def chosen_index(rows: list[dict[str, Any]]) -> int:
    """The candidate that succeeds most; then the one completing more stages; then the lower teacher-forced value
    (the rows come in that order)."""
    return max(range(len(rows)), key=lambda i: (rows[i]["successes"], rows[i]["stages_done"], -i))


def choose_by_rollouts(run: Path, task: str, episodes: int, workers: int = 1, max_keyframes: int = 0
                       ) -> dict[str, Any]:
    """Roll the run's candidates out, copy the winner over ``run/best`` and return the record of the choice."""
    folders = candidate_folders(run)
    if not folders:
        raise FileNotFoundError(f"{run} keeps no candidate checkpoints ({CANDIDATES_FOLDER}/); it was trained without "
                                "--select-rollouts, so train it again with it in a new --out")
    rows = roll_out_candidates(folders, task, episodes, workers, max_keyframes)
    pick = chosen_index(rows)
    best = run / "best"
    staged = run / "best.choosing"
    shutil.rmtree(staged, ignore_errors=True)
    shutil.copytree(folders[pick], staged, ignore=shutil.ignore_patterns(ROLLOUTS_FILE))
    config = read_json_file(staged / "config.json")
    config["closed_loop_choice"] = {"successes": rows[pick]["successes"], "episodes": rows[pick]["episodes"]}
    atomic_write_json(staged / "config.json", config)
    previous = run / "best.previous"
    shutil.rmtree(previous, ignore_errors=True)
    if best.exists():
        best.rename(previous)
    staged.rename(best)  # renames: an interrupted choice leaves a whole folder (best/ or best.previous/) to redo from
    shutil.rmtree(previous, ignore_errors=True)
    seeds = selection_seeds(episodes)
    return {"task": task, "seeds": [seeds[0], seeds[-1]], "episodes": episodes, "candidates": rows,
            "chosen_step": rows[pick]["step"], "teacher_forced_step": rows[0]["step"]}
