"""Commands for a robot: serve a checkpoint, run it on a (simulated) robot through the server."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Literal

import tyro

from bimanualshift.cli.common import command_line, resolve_tasks


def read_token(path: str) -> str | None:
    """The shared secret in ``path`` (its first line), or None without a path."""
    if not path:
        return None
    file = Path(path)
    if not file.is_file():
        raise FileNotFoundError(f"--token-file {path}: no such file (put a long random secret in it, e.g. "
                                f"`python -c 'import secrets; print(secrets.token_urlsafe(32))' > {path}`)")
    mode = file.stat().st_mode & 0o777
    if mode & 0o077:  # as ssh refuses a private key others can read: the token is what guards the robot
        raise PermissionError(f"--token-file {path}: permissions {mode:04o} let other users read or change the "
                              f"secret; run `chmod 600 {path}` (owner read/write only) and start again")
    lines = file.read_text().strip().splitlines()
    token = lines[0].strip() if lines else ""
    if len(token) < 16:
        raise ValueError(f"--token-file {path}: the token must be at least 16 characters, it has {len(token)}")
    return token


@dataclass
class ServeArgs:
    checkpoint: str = ""  # a trained BimanualShift run's best/ (or refine/best) folder
    prior: str = ""  # instead of --checkpoint: serve a frozen prior alone (with --method no_residual)
    method: str = "bimanualshift"  # its name in the registry (an ablation's checkpoint serves under its own name)
    host: str = "127.0.0.1"  # anything but loopback needs --token-file
    port: int = 8000
    token_file: str = ""  # clients must send 'Authorization: Api-Key <token>' (openpi-client's api_key)
    segmenter: str = ""  # replaces the checkpoint's: grounded_sam on a real robot (no simulator maps)
    max_message_mb: float = 32.0  # larger frames get an error reply (4x larger ones are closed unread)
    idle_timeout_s: float = 300.0
    max_connections: int = 32


def serve(args: ServeArgs) -> None:
    from bimanualshift.deploy.served_policy import load_served_policy
    from bimanualshift.deploy.server import PolicyServer, ServerConfig, check_bind

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    token = read_token(args.token_file)
    check_bind(args.host, token)  # before loading anything
    # a prior alone serves as no_residual unless another frozen-prior method is named
    method = "no_residual" if not args.checkpoint and args.method == "bimanualshift" else args.method
    served = load_served_policy(method, args.checkpoint, args.prior, args.segmenter)
    config = ServerConfig(args.host, args.port, token, int(args.max_message_mb * 2**20), args.idle_timeout_s,
                          args.max_connections)
    PolicyServer(served.policy, served.metadata, config, check=served.check).serve_forever()


@dataclass
class DeployArgs:
    robot: Literal["sim"] = "sim"  # a real robot plugs in through deploy.robot.Robot (docs/deploy.md)
    task: list[str] = field(default_factory=lambda: ["push_two_buttons"])  # the simulated robot's task(s)
    server: str = "ws://127.0.0.1:8000"
    token_file: str = ""
    episodes: int = 20  # per task
    split: Literal["validation", "test"] = "test"
    max_keyframes: int = 0  # as in `eval`: 0 = twice the expert's keyframes on the seed
    # a `bimanualshift calibrate` file: its static camera poses and base anchors replace the simulator's truth
    calibration: str = ""
    out: str = ""  # write a result JSON (per-seed success, round trips, clipping) here
    rrd: str = ""  # write every episode to this rerun recording (.rrd), as `eval --rrd` does: `rerun FILE.rrd`
    # where the policy plans keyframes ahead (a reply's `chunk`: the Diffusion Policy and ACT priors), run up to
    # this many of them, each through the safety filter, before reading the robot again; 1 asks at every keyframe
    chunk_steps: int = 1


def deploy(args: DeployArgs) -> None:
    from bimanualshift.data.seeds import split_seeds
    from bimanualshift.deploy.client import PolicyClient
    from bimanualshift.deploy.loop import deploy_sim, episode_row
    from bimanualshift.deploy.robot import Calibration
    from bimanualshift.evaluation.report import write_result
    from bimanualshift.evaluation.stats import wilson_interval

    if args.chunk_steps < 1:
        raise ValueError(f"--chunk-steps {args.chunk_steps}: give 1 (ask at every keyframe) or more")
    started = time.time()
    client = PolicyClient(args.server, read_token(args.token_file))
    seeds = split_seeds(args.split, args.episodes)
    recorder = None
    if args.rrd:
        from bimanualshift.evaluation.viewer import EpisodeRecorder

        recorder = EpisodeRecorder(args.rrd)
    rows = []
    for task in resolve_tasks(args.task):
        calibration = Calibration.load(args.calibration) if args.calibration else None
        records = deploy_sim(task, client, seeds, args.max_keyframes, calibration, recorder, args.chunk_steps)
        wins = sum(r.success for r in records)
        low, high = wilson_interval(wins, len(records))
        print(f"{task}: {wins}/{len(records)} ({100 * wins / len(records):.0f} %, 95 % CI {100 * low:.0f}-"
              f"{100 * high:.0f}); aborted {sum(bool(r.aborted) for r in records)}")
        rows += [episode_row(r) for r in records]
    client.close()
    if recorder is not None:
        recorder.close()
        print(f"wrote {args.rrd} (open it with `rerun {args.rrd}`)")
    if args.out:
        write_result(args.out, command_line(), {args.split: seeds}, started, rows, server=client.metadata)
        print(f"wrote {args.out}")


@dataclass
class CalibrateArgs:
    robot: Literal["sim"] = "sim"  # a real robot: collect (gripper pose, image) pairs with its driver, same solver
    task: str = "push_two_buttons"  # the simulated scene
    poses: int = 40  # gripper poses per arm (>= 15)
    width: int = 1280  # calibration views' resolution
    height: int = 960
    marker_length: float = 0.08  # metres, the black square's side
    pixel_noise: float = 0.5  # std of the noise added to detected corners (px)
    position_noise_mm: float = 1.0  # std of the noise on reported gripper positions
    rotation_noise_deg: float = 0.2  # std of the noise on reported gripper orientations
    method: Literal["tsai", "park", "horaud", "andreff", "daniilidis"] = "park"  # OpenCV's hand-eye method
    seed: int = 0
    out: str = "calibration.json"  # the calibration file (deploy --calibration, serve's base anchors)
    results: str = ""  # also write the errors against the simulator's truth here (results/calibration.json)


def calibrate(args: CalibrateArgs) -> None:
    from bimanualshift.deploy.calibration_sim import simulate_calibration
    from bimanualshift.evaluation.report import write_result

    if args.poses < 15:
        raise ValueError(f"--poses {args.poses}: use at least 15 gripper poses per arm")
    started = time.time()
    run = simulate_calibration(args.task, args.poses, args.width, args.height, args.marker_length,
                               args.pixel_noise, args.position_noise_mm, args.rotation_noise_deg, args.method,
                               args.seed)
    run.calibration.save(args.out)
    for row in run.rows:
        if row["stage"] == "joint":
            what = row.get("camera") or f"{row['arm_base']} base"
            print(f"{what:22s} {row['translation_error_mm']:6.2f} mm  {row['rotation_error_deg']:.3f} deg")
    print(f"reprojection RMS {run.reprojection_rms_px:.2f} px; wrote {args.out}")
    if args.results:
        write_result(args.results, command_line(), {"poses": [args.seed]}, started, run.rows,
                     notes="errors against the simulator's truth; stage hand_eye: OpenCV calibrateHandEye per "
                     "camera and arm (eye-to-hand, outliers dropped); stage joint: all cameras, the second base and "
                     "both marker mounts fitted to every view's corners",
                     reprojection_rms_px=round(run.reprojection_rms_px, 3),
                     detector_error_px_median=run.detector_error_px_median,
                     noise={"pixel": args.pixel_noise, "position_mm": args.position_noise_mm,
                            "rotation_deg": args.rotation_noise_deg})
        print(f"wrote {args.results}")


@dataclass
class ExportLerobotArgs:
    data: Annotated[str, tyro.conf.Positional]  # a folder of episodes (a sub-folder per task: `collect`, `record`)
    out: Annotated[str, tyro.conf.Positional]  # the LeRobot v3.0 dataset folder to write
    task: list[str] = field(default_factory=list)  # only these tasks (default: every task folder in DATA)
    # LeRobot's robot_type (default: bimanual_<robot> from the tasks' robot spec, e.g. bimanual_ur5e on the twin)
    robot_type: str = ""
    overwrite: bool = False


def robot_type_of(tasks: list[str]) -> str:
    """``bimanual_<spec>`` of the robot the tasks' episodes were recorded on (``Task.robot``, or the ``@robot`` of a
    variant); a task this process does not know (an imported dataset's) counts as the benchmark's Panda."""
    from bimanualshift.sim.task_registry import task_class, task_names

    known = set(task_names())
    robots = {task_class(t).robot if t in known else "panda" for t in tasks}
    if len(robots) > 1:
        raise ValueError(f"the tasks {', '.join(tasks)} were recorded on different robots "
                         f"({', '.join(sorted(robots))}): export each robot's tasks with its own --task list, or name "
                         "one --robot-type")
    return f"bimanual_{robots.pop()}"


def export_lerobot(args: ExportLerobotArgs) -> None:
    from bimanualshift.data.episode import read_episode
    from bimanualshift.data.lerobot_format import export_lerobot as write_dataset

    root = Path(args.data)
    if not root.is_dir():
        raise FileNotFoundError(f"{root}: no such folder of episodes")
    tasks = args.task or sorted(p.name for p in root.iterdir() if p.is_dir())
    paths = [p for t in tasks for p in sorted((root / t).glob("episode_*.h5"))]
    if not paths:
        raise FileNotFoundError(f"no episode_*.h5 files under {root}/{{{','.join(tasks)}}}")
    robot_type = args.robot_type or robot_type_of(tasks)
    out = write_dataset([read_episode(p) for p in paths], args.out, robot_type, args.overwrite)
    print(f"wrote {len(paths)} episodes to {out} (LeRobot v3.0)")


@dataclass
class ImportLerobotArgs:
    dataset: Annotated[str, tyro.conf.Positional]  # a LeRobot v3.0 dataset folder, or hf://datasets/ORG/NAME[@REV]
    out: str = "data/imported"  # where the episodes go (<out>/<task>/episode_<seed>.h5)
    calibration: str = ""  # arm base positions for a dataset that does not record them
    task: str = ""  # the task folder name for a dataset that does not record one (default: lerobot)
    # a joint-space dataset: a MuJoCo model (MJCF/URDF) whose joints carry the state's names and which has a site
    # <arm>_ee per arm, and the arm names the state's names start with
    kinematics: str = ""
    arms: list[str] = field(default_factory=list)


def import_lerobot(args: ImportLerobotArgs) -> None:
    from bimanualshift.data.episode import episode_path, write_episode
    from bimanualshift.data.kinematics import KinematicsModel
    from bimanualshift.data.lerobot_format import import_lerobot as read_dataset
    from bimanualshift.deploy.robot import Calibration
    from bimanualshift.utils.hub import resolve_local

    bases = Calibration.load(args.calibration).arm_bases if args.calibration else None
    kinematics = KinematicsModel(args.kinematics) if args.kinematics else None
    episodes = read_dataset(resolve_local(args.dataset, "dataset"), bases, kinematics, args.arms or None)
    for ep in episodes:
        if args.task:
            ep.task = args.task
        write_episode(episode_path(args.out, ep.task, ep.seed), ep)
    print(f"wrote {len(episodes)} episodes under {args.out}")


@dataclass
class RecordArgs:
    robot: Literal["sim"] = "sim"
    task: str = "push_two_buttons"
    teleop: Literal["scripted", "keyboard"] = "scripted"  # keyboard: w/s a/d r/f move, g gripper, tab arm, q done
    seeds: list[int] = field(default_factory=lambda: [0])  # one episode per seed (the scene's randomisation)
    out: str = "data/recorded"  # episodes go to <out>/<task>/episode_<seed>.h5
    keep_failures: bool = False


def record(args: RecordArgs) -> None:
    from bimanualshift.deploy.record import record as record_episodes
    from bimanualshift.deploy.teleop import KeyboardTeleop, ScriptedTeleop

    if args.teleop == "keyboard":
        import sys
        import termios
        import tty

        if not sys.stdin.isatty():
            raise ValueError("--teleop keyboard needs a terminal (or use --teleop scripted)")
        saved = termios.tcgetattr(sys.stdin)
        tty.setcbreak(sys.stdin.fileno())
        try:
            written = record_episodes(args.task, KeyboardTeleop(), args.seeds, args.out, args.keep_failures)
        finally:
            termios.tcsetattr(sys.stdin, termios.TCSADRAIN, saved)
    else:
        written = record_episodes(args.task, ScriptedTeleop(), args.seeds, args.out, args.keep_failures)
    print(f"wrote {len(written)} of {len(args.seeds)} episodes under {args.out}/{args.task}")
