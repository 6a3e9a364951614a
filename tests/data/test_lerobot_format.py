"""LeRobot v3.0 export and import: the layout LeRobot's own code reads, exact tables and depth, RGB within a
stated PSNR, and a clear list of what a foreign dataset lacks."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from bimanualshift.data.collect import collect
from bimanualshift.data.episode import list_episodes, read_episode, write_episode
from bimanualshift.data.kinematics import KinematicsModel
from bimanualshift.data.lerobot_format import LeRobotFormatError, export_lerobot, import_lerobot

RGB_PSNR_DB = 30.0  # AV1 at crf 30 (LeRobot's own setting); measured ~37 dB on the benchmark's 128x128 views


@pytest.fixture(scope="module")
def exported(demo_root: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[list, Path]:
    episodes = [read_episode(p) for p in list_episodes(demo_root / "bimanual", "push_two_buttons")]
    out = export_lerobot(episodes, tmp_path_factory.mktemp("lerobot") / "dataset")
    return episodes, out


@pytest.fixture(scope="module")
def exported_twin(tmp_path_factory: pytest.TempPathFactory) -> tuple[list, Path]:
    """Two demos of a real-world task on the UR5e twin: one 256x256 front camera, UR5e arms, Robotiq grippers."""
    root = tmp_path_factory.mktemp("twin_demos")
    collect(["vegetable_sorting"], [0, 1], root)
    episodes = [read_episode(p) for p in list_episodes(root, "vegetable_sorting")]
    assert len(episodes) == 2, "the twin's expert failed a vegetable_sorting demo"
    return episodes, export_lerobot(episodes, root / "dataset")


def test_layout_follows_lerobot_v3(exported: tuple[list, Path]) -> None:
    episodes, out = exported
    info = json.loads((out / "meta/info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["total_episodes"] == len(episodes)
    assert info["data_path"] == "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    assert info["video_path"] == "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
    for key in ("timestamp", "frame_index", "episode_index", "index", "task_index"):
        assert info["features"][key]["shape"] == [1]
    cam = episodes[0].camera_names[0]
    assert info["features"][f"observation.images.{cam}"]["dtype"] == "video"
    assert info["features"][f"observation.depth.{cam}"]["dtype"] == "float32"
    assert (out / f"videos/observation.images.{cam}/chunk-000/file-000.mp4").is_file()
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    assert data.num_rows == info["total_frames"] == sum(e.num_keyframes for e in episodes)
    meta = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert [m["length"] for m in meta] == [e.num_keyframes for e in episodes]
    assert meta[1]["dataset_from_index"] == meta[0]["dataset_to_index"]
    tasks = pq.read_table(out / "meta/tasks.parquet").to_pandas()
    assert tasks.loc[episodes[0].instruction, "task_index"] == 0  # indexed by the task string, as lerobot reads it
    stats = json.loads((out / "meta/stats.json").read_text())
    assert len(stats["observation.state"]["mean"]) == 8 * len(episodes[0].arm_names)


@pytest.mark.parametrize("dataset", ["exported", "exported_twin"])
def test_round_trip(dataset: str, request: pytest.FixtureRequest) -> None:
    episodes, out = request.getfixturevalue(dataset)
    back = import_lerobot(out)
    assert len(back) == len(episodes)
    for a, b in zip(episodes, back):
        for key in ("depth", "instance", "class", "intrinsics", "extrinsics", "proprio", "actions"):
            assert a.arrays[key].dtype == b.arrays[key].dtype and np.array_equal(a.arrays[key], b.arrays[key]), key
        mse = np.mean((a.arrays["rgb"].astype(float) - b.arrays["rgb"].astype(float)) ** 2)
        assert 10 * np.log10(255**2 / mse) > RGB_PSNR_DB
        assert (a.task, a.seed, a.instruction, a.arm_bases, a.goal_nouns) == (
            b.task, b.seed, b.instruction, b.arm_bases, b.goal_nouns)
        if a.dense is not None:
            assert all(np.array_equal(a.dense[k], b.dense[k]) for k in a.dense)
        assert b.camera_names == a.camera_names and b.arrays["rgb"].shape == a.arrays["rgb"].shape


def test_missing_features_are_named(exported: tuple[list, Path], tmp_path: Path) -> None:
    _, out = exported
    info = json.loads((out / "meta/info.json").read_text())
    cam = info["bimanualshift"]["camera_names"][0]
    del info["features"][f"observation.depth.{cam}"]
    info["features"]["observation.state"]["names"] = ["left_joint1", "left_joint2"]
    (tmp_path / "meta").mkdir()
    (tmp_path / "meta/info.json").write_text(json.dumps(info))
    with pytest.raises(LeRobotFormatError) as err:
        import_lerobot(tmp_path)
    assert f"observation.depth.{cam}" in str(err.value) and "kinematics" in str(err.value)
    with pytest.raises(LeRobotFormatError, match="no meta/info.json"):
        import_lerobot(tmp_path / "nothing")


ARM_XML = """<mujoco><worldbody>
  <body name="{arm}_link" pos="0 {y} 1"><joint name="{arm}_joint1" type="hinge" axis="0 0 1"/>
    <geom size="0.02"/><site name="{arm}_ee" pos="0.5 0 0"/></body></worldbody></mujoco>"""


def test_joint_space_states_through_a_kinematics_model(tmp_path: Path) -> None:
    xml = ("<mujoco><worldbody>" + "".join(ARM_XML.format(arm=a, y=y).split("<worldbody>")[1].split("</worldbody>")[0]
                                           for a, y in (("left", 0.3), ("right", -0.3))) + "</worldbody></mujoco>")
    (tmp_path / "arms.xml").write_text(xml)
    model = KinematicsModel(tmp_path / "arms.xml")
    state = np.array([[0.0, np.pi / 2, 1.0, 0.0]])  # left_joint1, right_joint1, grippers
    poses = model.ee_poses(state, ["left_joint1", "right_joint1", "left_gripper", "right_gripper"], ["left", "right"])
    assert np.allclose(poses[0, 0, :3], [0.5, 0.3, 1.0]) and np.allclose(poses[0, 1, :3], [0.0, 0.2, 1.0])
    with pytest.raises(ValueError, match="no site"):
        model.ee_poses(state, ["left_joint1", "right_joint1"], ["middle"])
    with pytest.raises(FileNotFoundError, match="no such model"):
        KinematicsModel(tmp_path / "missing.xml")


def test_a_joint_space_dataset_imports_through_kinematics(exported: tuple[list, Path], tmp_path: Path) -> None:
    import shutil

    import pyarrow as pa

    _, out = exported
    joint = tmp_path / "joint_space"
    shutil.copytree(out, joint)
    info = json.loads((joint / "meta/info.json").read_text())
    names = ["left_joint1", "right_joint1", "left_gripper", "right_gripper"]
    info["features"]["observation.state"] = {"dtype": "float32", "shape": [4], "names": names}
    del info["bimanualshift"]
    (joint / "meta/info.json").write_text(json.dumps(info))
    data_path = joint / "data/chunk-000/file-000.parquet"
    table = pq.read_table(data_path)
    n = table.num_rows
    state = np.stack([np.linspace(0, 1, n), np.linspace(0, -1, n), np.ones(n), np.zeros(n)], 1).astype(np.float32)
    column = pa.FixedSizeListArray.from_arrays(pa.array(state.reshape(-1)), 4)
    pq.write_table(table.set_column(table.schema.get_field_index("observation.state"), "observation.state", column),
                   data_path)
    with pytest.raises(LeRobotFormatError, match="kinematics"):
        import_lerobot(joint)
    xml = ("<mujoco><worldbody>" + "".join(ARM_XML.format(arm=a, y=y).split("<worldbody>")[1].split("</worldbody>")[0]
                                           for a, y in (("left", 0.3), ("right", -0.3))) + "</worldbody></mujoco>")
    (tmp_path / "arms.xml").write_text(xml)
    back = import_lerobot(joint, kinematics=KinematicsModel(tmp_path / "arms.xml"), arms=["left", "right"])
    proprio = np.concatenate([b.arrays["proprio"] for b in back])
    assert proprio.shape == (n, 2, 8)
    angle = state[:, 0]
    np.testing.assert_allclose(proprio[:, 0, :3], np.stack([0.5 * np.cos(angle), 0.3 + 0.5 * np.sin(angle),
                                                            np.ones(n)], 1), atol=1e-5)
    assert (proprio[:, 0, 7] == 1).all() and (proprio[:, 1, 7] == 0).all()


def test_the_command_names_the_robot_the_demos_were_recorded_on(exported_twin: tuple[list, Path],
                                                                 tmp_path: Path) -> None:
    from bimanualshift.cli.deploy import ExportLerobotArgs, robot_type_of
    from bimanualshift.cli.deploy import export_lerobot as export_command

    episodes, _ = exported_twin
    data = tmp_path / "data" / "vegetable_sorting"
    data.mkdir(parents=True)
    for e in episodes:
        write_episode(data / f"episode_{e.seed}.h5", e)
    export_command(ExportLerobotArgs(data=str(tmp_path / "data"), out=str(tmp_path / "ds")))
    assert json.loads((tmp_path / "ds" / "meta" / "info.json").read_text())["robot_type"] == "bimanual_ur5e"
    assert robot_type_of(["push_two_buttons"]) == "bimanual_panda"
    with pytest.raises(ValueError, match="different robots"):
        robot_type_of(["push_two_buttons", "vegetable_sorting"])
