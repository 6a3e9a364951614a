"""Episodes in the rerun viewer: a failed episode recorded as it runs, and a logged one written by `view`, are
opened again with rerun's own reader and hold each camera, each arm's projection, the actions and the scalars."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bimanualshift.cli import main
from bimanualshift.data.frames import scene_of_env
from bimanualshift.evaluation.viewer import EpisodeRecorder, read_recording
from bimanualshift.rollout.loop import rollout
from bimanualshift.sim.env import ManipulationEnv


class StandStill:
    """Commands each arm to where it is (the task fails), logging a fixed proposal 10 cm below it."""

    name = "stand_still"

    def reset(self) -> None:
        self.proprio = None

    def act(self, obs) -> np.ndarray:  # noqa: ANN001
        self.proprio = np.asarray(obs.proprio, np.float32)
        return np.concatenate([self.proprio, np.ones((len(self.proprio), 1), np.float32)], axis=1)

    def keyframe_log(self) -> dict:
        arms = []
        for arm, row in zip(("left", "right"), self.proprio):
            prior = row[:7].copy()
            prior[2] -= 0.1
            arms.append({"arm": arm, "prior": prior.tolist(), "residual_cm": 10.0, "held": arm == "right"})
        return {"arms": arms, "retrieval": {"similarity": 0.5, "fired": False}}


@pytest.mark.slow
def test_a_failed_episode_recorded_as_it_runs(tmp_path: Path) -> None:
    env = ManipulationEnv("push_two_buttons", image_size=32)
    recorder = EpisodeRecorder(tmp_path / "run.rrd", points_per_camera=200)
    record = rollout(env, StandStill(), seed=3, max_keyframes=2, observer=recorder)
    recorder.close()
    cameras = list(scene_of_env(env).camera_names)
    env.close()
    assert not record.success
    seen = read_recording(tmp_path / "run.rrd")
    root = "/push_two_buttons/stand_still/seed_3"
    assert seen["keyframes"] == [0, 1]
    for camera in cameras:
        assert {f"{root}/cameras/{camera}/rgb", f"{root}/cameras/{camera}/depth"} <= set(seen["entities"])
    for arm in ("left", "right"):
        kept, removed = seen["points"][f"{root}/arms/{arm}/kept"], seen["points"][f"{root}/arms/{arm}/removed"]
        assert all(k > 0 and r > 0 for k, r in zip(kept, removed))  # the other arm and clutter vanish, the rest stays
        assert [k + r for k, r in zip(kept, removed)] == seen["points"][f"{root}/scene"]
        assert seen["scalars"][f"{root}/arms/{arm}/residual_cm"] == [10.0, 10.0]
        assert f"{root}/arms/{arm}/residual" in seen["entities"]  # the arrow from the proposal to the action
    assert seen["scalars"][f"{root}/arms/right/held"] == [1.0, 1.0]
    assert seen["scalars"][f"{root}/retrieval/similarity"] == [0.5, 0.5]
    assert seen["scalars"][f"{root}/stages_done"] == [0.0, 0.0]


def _bench_folder(folder: Path) -> None:
    step = {"executed": [[0.1, 0.2, 1.0, 1, 0, 0, 0, 1, 1]] * 2, "expert": [[0.1, 0.2, 0.9, 1, 0, 0, 0, 1, 1]] * 2,
            "stages_done": 0}
    logs, episodes = [], []
    for seed, success in ((7, True), (8, False)):
        logs.append({"task": "push_two_buttons", "method": "m", "perturbation": "none", "seed": seed,
                     "steps": [{**step, "keyframe": k} for k in range(3)]})
        episodes.append({"task": "push_two_buttons", "method": "m", "perturbation": "none", "seed": seed,
                         "success": success})
    folder.mkdir()
    (folder / "keyframes.jsonl").write_text("".join(json.dumps(e) + "\n" for e in logs))
    (folder / "episodes.jsonl").write_text("".join(json.dumps(e) + "\n" for e in episodes))


def test_view_writes_the_first_failed_logged_episode(tmp_path: Path) -> None:
    _bench_folder(tmp_path / "bench")
    out = tmp_path / "view.rrd"
    main(["view", str(tmp_path / "bench"), "--out", str(out), "--render", "false"])
    seen = read_recording(out)
    assert {e.split("/")[3] for e in seen["entities"]} == {"seed_8"}  # the failed one, not seed 7
    assert seen["points"]["/push_two_buttons/m/seed_8/arms/0/expert"] == [1, 1, 1]
    with pytest.raises(SystemExit, match="no logged episode .* matches task lift_ball"):
        main(["view", str(tmp_path / "bench"), "--task", "lift_ball", "--render", "false"])
    with pytest.raises(SystemExit, match="no keyframes.jsonl there"):
        main(["view", str(tmp_path / "bench" / "missing.jsonl")])


@pytest.mark.slow
def test_eval_records_its_episodes(tmp_path: Path) -> None:
    out = tmp_path / "eval.rrd"
    main(["eval", "--method", "no_residual", "--prior", "peract_suite", "--task", "push_two_buttons", "--episodes",
          "1", "--max-keyframes", "1", "--rrd", str(out)])
    seen = read_recording(out)
    assert seen["keyframes"] == [0]
    assert seen["points"]["/push_two_buttons/no_residual/seed_200000/arms/right/prior"] == [1]
