"""Episodes in the rerun viewer (`eval --rrd FILE.rrd`, `bench --rrd FILE.rrd`, `bimanualshift view`): one
recording, a ``keyframe`` timeline, an entity tree per episode (``TASK/METHOD/seed_S``) holding

- each camera's RGB and depth, posed by its extrinsics and intrinsics (``cameras/NAME``);
- the scene's points, and per arm the points its arm-conditioned projection keeps and removes (``arms/ARM/kept``,
  ``arms/ARM/removed``);
- per arm the prior's proposal, the executed action, the expert's keyframe and the pose reached, with the
  residual drawn as an arrow from proposal to action (``arms/ARM/...``);
- scalars: the residual's size, the gripper command, holds, the retrieval's similarity and the stages reached.

Open the file with `rerun FILE.rrd` (rerun-sdk's own viewer). rerun-sdk is imported only by this module.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from bimanualshift.data.frames import KeyframeObservation

KEYFRAME = "keyframe"  # the timeline
POINTS_PER_CAMERA = 6000  # a fixed subsample of each camera's pixels keeps a recording near 1 MB per keyframe
REMOVED_COLOUR = (120, 120, 120)


def _rerun():  # noqa: ANN202
    try:
        import rerun as rr
    except ImportError as err:
        raise ImportError("the episode viewer needs rerun-sdk: pip install 'bimanualshift[viewer]' "
                          "(rerun-sdk==0.23.1, the newest release for numpy 1.26)") from err
    return rr


def episode_path(task: str, method: str, seed: int) -> str:
    return f"{task}/{method}/seed_{seed}"


class EpisodeRecorder:
    """Writes episodes into one ``.rrd`` file as they run (``keyframe``) and closes it (``close``)."""

    def __init__(self, path: str | Path, points_per_camera: int = POINTS_PER_CAMERA, projection: bool = True,
                 recording_id: str | None = None) -> None:
        """``recording_id``: files written apart (the benchmark's workers) that merge into one recording."""
        rr = _rerun()
        self.rr = rr
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.rec = rr.RecordingStream("bimanualshift", recording_id=recording_id)
        self.rec.save(str(self.path))
        self.points_per_camera = points_per_camera
        self.projection = None
        if projection:  # the simulator's segmentation: the masks the projection keeps, per arm
            from bimanualshift.perception.projection import ArmProjection
            from bimanualshift.perception.segmenters import make_segmenter

            self.projection = ArmProjection(make_segmenter("simulator"))

    def episode(self, task: str, method: str, seed: int, instruction: str) -> str:
        root = episode_path(task, method, seed)
        self.rec.set_time(KEYFRAME, sequence=0)
        self.rec.log(f"{root}/instruction", self.rr.TextLog(instruction))
        return root

    def keyframe(self, root: str, k: int, obs: KeyframeObservation | None, row: dict[str, Any]) -> None:
        """Keyframe ``k`` of the episode under ``root``: what the cameras saw (``obs``, when there is one) and
        the keyframe's log row (``rollout.loop.keyframe_row``)."""
        rr, rec = self.rr, self.rec
        rec.set_time(KEYFRAME, sequence=k)
        if obs is not None:
            self._cameras(root, obs)
        policy = row.get("policy") or {}
        arms = policy.get("arms") or []
        names = [a.get("arm", str(i)) for i, a in enumerate(arms)] or [str(i) for i in range(len(row["executed"]))]
        for i, arm in enumerate(names):
            base = f"{root}/arms/{arm}"
            executed = np.asarray(row["executed"][i], np.float32)
            rec.log(f"{base}/executed", rr.Points3D(executed[None, :3], radii=0.012, colors=(40, 160, 255)))
            rec.log(f"{base}/gripper_open", rr.Scalars(float(executed[7])))
            if row.get("expert") is not None:
                rec.log(f"{base}/expert", rr.Points3D(np.asarray(row["expert"][i], np.float32)[None, :3],
                                                      radii=0.012, colors=(60, 200, 90)))
            if row.get("reached") is not None:
                rec.log(f"{base}/reached", rr.Points3D(np.asarray(row["reached"][i], np.float32)[None, :3],
                                                       radii=0.008, colors=(255, 255, 255)))
            if i < len(arms):
                decision = arms[i]
                prior = np.asarray(decision["prior"], np.float32)[:3]
                rec.log(f"{base}/prior", rr.Points3D(prior[None], radii=0.012, colors=(255, 160, 30)))
                rec.log(f"{base}/residual", rr.Arrows3D(origins=prior[None], vectors=(executed[:3] - prior)[None],
                                                        colors=(255, 80, 80)))
                rec.log(f"{base}/residual_cm", rr.Scalars(float(decision.get("residual_cm", 0.0))))
                rec.log(f"{base}/held", rr.Scalars(float(bool(decision.get("held", False)))))
        retrieval = policy.get("retrieval")
        if retrieval:
            rec.log(f"{root}/retrieval/similarity", rr.Scalars(float(retrieval["similarity"])))
            rec.log(f"{root}/retrieval/fired", rr.Scalars(float(bool(retrieval.get("fired")))))
        rec.log(f"{root}/stages_done", rr.Scalars(float(row.get("stages_done", 0))))

    def replay(self, root: str, k: int, stages_done: int, reached_gap_cm: np.ndarray) -> None:
        """A re-simulated keyframe's own outcome beside the logged one (``record_logged``)."""
        self.rec.set_time(KEYFRAME, sequence=k)
        self.rec.log(f"{root}/replay/stages_done", self.rr.Scalars(float(stages_done)))
        for i, gap in enumerate(reached_gap_cm):
            self.rec.log(f"{root}/replay/reached_gap_cm/{i}", self.rr.Scalars(float(gap)))

    def _cameras(self, root: str, obs: KeyframeObservation) -> None:
        from bimanualshift.perception.observation import fixed_subsample, world_point_cloud

        rr, rec = self.rr, self.rec
        points, colours = world_point_cloud(obs)
        masks = self.projection.masks_2d(obs) if self.projection is not None else {}
        chosen = []
        for c, camera in enumerate(obs.scene.camera_names):
            height, width = obs.depth[c].shape
            intr, extr = obs.intrinsics[c], obs.extrinsics[c]  # extrinsics: camera-to-world, OpenCV axes
            path = f"{root}/cameras/{camera}"
            rec.log(path, rr.Transform3D(translation=extr[:3, 3], mat3x3=extr[:3, :3]))
            rec.log(path, rr.Pinhole(image_from_camera=intr, width=width, height=height,
                                     camera_xyz=rr.ViewCoordinates.RDF))
            rec.log(f"{path}/rgb", rr.Image(obs.rgb[c]))
            rec.log(f"{path}/depth", rr.DepthImage(np.nan_to_num(obs.depth[c]), meter=1.0))
            valid = np.flatnonzero(np.isfinite(obs.depth[c]).ravel() & (obs.depth[c].ravel() > 0))
            chosen.append((c, fixed_subsample(valid, self.points_per_camera)))
        xyz = np.concatenate([points[c].reshape(-1, 3)[i] for c, i in chosen])
        rgb = np.concatenate([colours[c].reshape(-1, 3)[i] for c, i in chosen])
        rec.log(f"{root}/scene", rr.Points3D(xyz, colors=rgb, radii=0.003))
        for arm, mask in masks.items():
            keep = np.concatenate([mask[c].ravel()[i] for c, i in chosen])
            rec.log(f"{root}/arms/{arm}/kept", rr.Points3D(xyz[keep], colors=rgb[keep], radii=0.004))
            rec.log(f"{root}/arms/{arm}/removed", rr.Points3D(xyz[~keep], colors=REMOVED_COLOUR, radii=0.002))

    def close(self) -> None:
        self.rec.flush(blocking=True)
        self.rec.disconnect()


def read_recording(path: str | Path) -> dict[str, Any]:
    """What a recording holds, for checks and scripts: its entity paths, and in keyframe order each scalar
    entity's values and each point entity's point count (None where a keyframe logged nothing there)."""
    import rerun.dataframe as rd

    table = rd.load_recording(str(path)).view(index=KEYFRAME, contents="/**").select().read_all()
    entities, scalars, points = set(), {}, {}
    for name in table.column_names:
        entity, _, component = name.partition(":")
        if not component:
            continue
        entities.add(entity)
        cells = table.column(name).to_pylist()
        if component == "Scalar":
            scalars[entity] = [cell[0] if cell else None for cell in cells]
        elif component == "Position3D":
            points[entity] = [len(cell) if cell is not None else None for cell in cells]
    return {"entities": sorted(entities), "scalars": scalars, "points": points,
            "keyframes": table.column(KEYFRAME).to_pylist()}


def record_demo(path: str | Path, recorder: EpisodeRecorder) -> str:
    """A demo's episode file: its cameras at every keyframe and its keyframe actions (as the executed ones)."""
    from bimanualshift.data.episode import read_episode
    from bimanualshift.data.frames import KeyframeObservation

    episode = read_episode(path)
    root = recorder.episode(episode.task, "demo", episode.seed, episode.instruction)
    for k in range(episode.num_keyframes):
        row = {"keyframe": k, "executed": episode["actions"][k].tolist(), "expert": None, "stages_done": 0}
        recorder.keyframe(root, k, KeyframeObservation.from_episode(episode, k), row)
    return root


def record_logged(entry: dict[str, Any], recorder: EpisodeRecorder, render: bool = True) -> str:
    """A logged episode (a line of a ``keyframes.jsonl``). With ``render`` the episode is re-simulated from its
    seed, executing the logged actions, so the recording has what the cameras saw; the log keeps actions to
    0.1 mm, so the replayed contacts can differ slightly from the original run's."""
    task, method, seed, steps = entry["task"], entry["method"], int(entry["seed"]), entry["steps"]
    if not render:
        root = recorder.episode(task, method, seed, "")
        for row in steps:
            recorder.keyframe(root, int(row["keyframe"]), None, row)
        return root
    from bimanualshift.data.frames import KeyframeObservation, scene_of_env
    from bimanualshift.sim.env import ManipulationEnv
    from bimanualshift.sim.perturbations import preset

    env = ManipulationEnv(task, perturbations=preset(entry.get("perturbation", "none")))
    try:
        obs, _ = env.reset(seed=seed)
        scene = scene_of_env(env)
        root = recorder.episode(task, method, seed, env.task.instruction())
        for row in steps:
            recorder.keyframe(root, int(row["keyframe"]), KeyframeObservation.from_env(obs, scene), row)
            obs, _, _, _, info = env.step(np.asarray(row["executed"], np.float32))
            # how far the replay strays from the run it re-creates: the stages it reached, and its arms'
            # distance from the poses the run's arms reached
            gap = (np.linalg.norm(np.asarray(obs["proprio"])[:, :3] - np.asarray(row["reached"])[:, :3], axis=1)
                   if row.get("reached") is not None else np.zeros(0))
            recorder.replay(root, int(row["keyframe"]), int(info["stages_done"]), 100 * gap)
    finally:
        env.close()
    return root


def merge_recordings(parts: list[Path], out: str | Path) -> Path:
    """One ``.rrd`` of ``parts`` (rerun's own `rerun rrd merge`); parts written with one recording id become one
    recording."""
    import shutil
    import subprocess
    import sys

    from bimanualshift.utils.io import atomic_writer

    binary = shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))
    out = Path(out)
    with atomic_writer(out) as tmp, open(tmp, "wb") as sink:
        done = subprocess.run([binary, "rrd", "merge", *map(str, parts)], stdout=sink, stderr=subprocess.PIPE)
        if done.returncode != 0:
            raise RuntimeError(f"`rerun rrd merge` failed on {len(parts)} parts: {done.stderr.decode()[-500:]}")
    return out
