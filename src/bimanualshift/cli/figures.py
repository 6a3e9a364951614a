"""Figures: the arm-conditioned projection as a picture (the paper's Fig. 3)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


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
