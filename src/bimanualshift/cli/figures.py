"""Figures: the arm-conditioned projection as a picture (the paper's Fig. 3); episodes in the rerun viewer."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

import tyro


@dataclass
class ProjectionFigureArgs:
    task: list[str] = field(default_factory=lambda: ["bimanual"])  # bimanual task name(s), or bimanual
    seed: int = 0
    keyframe: int | None = None  # show the scene after this many expert keyframes (default: half)
    segmenter: str = "simulator"  # simulator, degraded-mild, degraded-strong
    image_size: int = 128
    out: str = "docs/img/projection"  # output folder


def projection(args: ProjectionFigureArgs) -> None:
    from bimanualshift.cli.common import resolve_tasks
    from bimanualshift.data.frames import KeyframeObservation, scene_of_env
    from bimanualshift.perception.projection import ArmProjection
    from bimanualshift.perception.segmenters import make_segmenter
    from bimanualshift.sim.env import ManipulationEnv
    from bimanualshift.viz.projection_figure import projection_figure

    out = Path(args.out)
    for task in resolve_tasks(args.task):
        env = ManipulationEnv(task, image_size=args.image_size)
        if not env.task.bimanual:
            raise ValueError(f"{task} is a single-arm task; the projection separates two arms")
        obs, _ = env.reset(seed=args.seed)
        keyframes = env.expert_keyframes()
        index = len(keyframes) // 2 if args.keyframe is None else min(args.keyframe, len(keyframes))
        for keyframe in keyframes[:index]:
            obs, *_ = env.step(env.action_from_keyframe(keyframe))
        frame = KeyframeObservation.from_env(obs, scene_of_env(env))
        projection = ArmProjection(make_segmenter(args.segmenter, seed=args.seed))
        path = projection_figure(frame, projection, out / f"{task}.png",
                                 title=f"{task}, seed {args.seed}, keyframe {index}: {env.task.instruction()!r}")
        print(f"{path} ({args.segmenter} segmenter)")
        env.close()


@dataclass
class ViewArgs:
    # a keyframes.jsonl (or a bench/study folder holding one), or a demo's episode_*.h5
    log: Annotated[str, tyro.conf.Positional, tyro.conf.arg(metavar="EPISODE_LOG")]
    out: str = ""  # the .rrd to write (default: beside the log, named by the episodes chosen)
    task: str = ""  # only this task's episodes
    method: str = ""  # only this method's
    seed: list[int] = field(default_factory=list)  # only these seeds (default: the first failed episode)
    all: bool = False  # every episode that matches (default: the first failed one, else the first)
    render: bool = True  # re-simulate each episode from its seed for the cameras (False: actions and scalars only)


def view(args: ViewArgs) -> None:
    from bimanualshift.evaluation.stats import episode_key
    from bimanualshift.evaluation.viewer import EpisodeRecorder, record_demo, record_logged
    from bimanualshift.utils.jsonl import read_records

    source = Path(args.log)
    if source.suffix == ".h5":
        out = Path(args.out or source.with_suffix(".rrd"))
        recorder = EpisodeRecorder(out)
        record_demo(source, recorder)
        recorder.close()
        print(f"wrote {out} (open it with `rerun {out}`)")
        return
    logs = [source] if source.is_file() else sorted(source.rglob("keyframes.jsonl"))
    logs = [p for p in logs if "superseded" not in p.parts]
    if not logs:
        raise FileNotFoundError(f"{source}: no keyframes.jsonl there; give a bench folder, its keyframes.jsonl "
                                "or an episode_*.h5")
    entries = [e for p in logs for e in read_records(p)
               if (not args.task or e.get("task") == args.task) and (not args.method or e.get("method") == args.method)
               and (not args.seed or int(e.get("seed", -1)) in args.seed)]
    if not entries:
        raise ValueError(f"no logged episode in {source} matches task {args.task or 'any'}, method "
                         f"{args.method or 'any'}, seeds {args.seed or 'any'}")
    if not args.all and not args.seed:
        outcomes = _outcomes(logs)
        failed = [e for e in entries if outcomes.get(episode_key(e)) is False]
        entries = (failed or entries)[:1]
    first = entries[0]
    out = Path(args.out or logs[0].parent / f"{first['task']}_{first['method']}_{first['seed']}.rrd")
    recorder = EpisodeRecorder(out)
    for entry in entries:
        record_logged(entry, recorder, render=args.render)
    recorder.close()
    print(f"wrote {out}: {len(entries)} episode(s) (open it with `rerun {out}`)")


def _outcomes(logs: list[Path]) -> dict[tuple, bool]:
    """(task, method, perturbation, seed) -> success, from the episodes.jsonl beside each keyframes log."""
    from bimanualshift.evaluation.stats import episode_key
    from bimanualshift.utils.jsonl import read_records

    out = {}
    for log in logs:
        path = log.with_name("episodes.jsonl")
        for e in read_records(path) if path.is_file() else []:
            out[episode_key(e)] = bool(e["success"])
    return out
