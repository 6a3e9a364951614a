"""The command table and the one place errors become ``error: ...`` lines (exit status 2)."""

from __future__ import annotations

import argparse
import importlib
import sys
import typing
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bimanualshift.utils.config_files import CheckpointError, config_from_dict, read_json_file
from bimanualshift.utils.pipes import quiet_on_closed_pipe
from bimanualshift.utils.plugins import PluginError, add_plugins
from bimanualshift.utils.progress import slow_bars_in_logs

DESCRIPTION = """BimanualShift: reuse a frozen single-arm policy for both arms of a bimanual robot.

Typical flow:
  bimanualshift collect  --task push_button --episodes 80 --out data/unimanual
  bimanualshift pretrain --data data/unimanual --out runs/prior
  bimanualshift collect  --task push_two_buttons --episodes 20 --out data/bimanual
  bimanualshift train    --task push_two_buttons --prior runs/prior/best --data data/bimanual
  bimanualshift eval     --checkpoint runs/bimanualshift/best --episodes 20
or everything at once:   bimanualshift demo

`bimanualshift COMMAND --help` lists a command's options. Anywhere on the line: --plugin MODULE imports your own
tasks or priors (docs/extending.md), --debug shows an error's full traceback.
"""


@dataclass(frozen=True)
class Command:
    target: str  # "module:function" under bimanualshift.cli; the function's one argument is its typed options
    help: str
    config_file: bool = False  # --config FILE.json gives the options (a run's saved config.json); flags override
    subcommands: dict[str, Command] = field(default_factory=dict)


COMMANDS: dict[str, Command] = {
    "tasks": Command("simulate:tasks", "list the registered tasks"),
    "collect": Command("simulate:collect", "record scripted-expert demonstrations to HDF5 (successes only)"),
    "experts": Command("simulate:experts", "measure the scripted experts' success rate on test seeds (no rendering)"),
    "snapshot": Command("simulate:snapshot", "render a picture of each task's first scene (for the docs)"),
    "video": Command("simulate:video", "record the scripted expert solving each task to MP4 (for the docs)"),
    "viz": Command("", "figures: `viz projection` draws the arm-conditioned projection (paper Fig. 3)", subcommands={
        "projection": Command("figures:projection", "the voxel scene and each arm's projected view, a PNG per task")}),
    "projection-quality": Command("evaluate:projection_quality", "measure how well the projection keeps each arm + "
                                  "goal and removes the other arm (voxels, simulator ground truth)"),
    "prior-report": Command("evaluate:prior_report", "single-arm success, size and speed of frozen priors "
                            "(results/priors.json)"),
    "pretrain": Command("train:pretrain", "pretrain a single-arm prior on single-arm demos only", config_file=True),
    "train": Command("train:train", "train the residual branch on bimanual demos (prior frozen)", config_file=True),
    "refine": Command("train:refine", "retrieval-conditioned refinement: roll out on training scenes, correct "
                      "failures with the expert, fine-tune the residual, grow the memory bank", config_file=True),
    "bench": Command("evaluate:bench", "methods x bimanual tasks on fixed seeds: train, evaluate in parallel, table, "
                     "plot, videos (resumable)", config_file=True),
    "ship-prior": Command("train:ship_prior", "copy a pretrained prior (a run's best/) into checkpoints/NAME/ with "
                          "its model card (<= 25 MB)"),
    "study": Command("evaluate:study", "one of the paper's studies as benchmark runs, combined into "
                     "results/<study>/"),
    "plot": Command("evaluate:plot", "redraw a bench or study folder's plots (success.png, stages.png) from its "
                    "summary.json, without running anything"),
    "eval": Command("evaluate:evaluate", "evaluate a method on held-out seeds"),
    "explain": Command("evaluate:explain", "where each method's failures happen in a bench folder: the stage "
                       "reached and the first keyframe and arm that strayed from the expert"),
    "demo": Command("demo:demo", "collect, (pre)train, train the residual, evaluate: the whole method",
                    config_file=True),
    "serve": Command("deploy:serve", "serve a checkpoint to robots over a websocket (openpi-compatible; token, "
                     "size limits, structured errors)"),
    "deploy": Command("deploy:deploy", "run a served checkpoint on a robot (--robot sim: the benchmark scene) "
                      "through the policy server"),
    "calibrate": Command("deploy:calibrate", "camera-to-base calibration from gripper poses and ArUco detections "
                         "(--robot sim: rendered views, errors against the simulator's truth)"),
    "record": Command("deploy:record", "record demonstrations by teleoperation (--teleop scripted|keyboard) with "
                      "dense trajectories and discovered keyframes"),
    "export-lerobot": Command("deploy:export_lerobot", "write episodes as a LeRobot v3.0 dataset (parquet + AV1 "
                              "video; depth exact in parquet)"),
    "import-lerobot": Command("deploy:import_lerobot", "read a LeRobot v3.0 dataset back into episodes (says which "
                              "features are missing)"),
    "report": Command("evaluate:report", "regenerate the README tables from the result files"),
    "view": Command("figures:view", "write a logged episode (a bench folder's keyframes.jsonl, re-simulated for its "
                    "cameras) or a demo's episode file as a rerun recording (.rrd)"),
    "push": Command("share:push", "share a prior, checkpoint (with its memory bank) or dataset on the Hugging Face "
                    "Hub with a model card from its config and result files (--dry-run: what would be sent)"),
    "pull": Command("share:pull", "download a prior, checkpoint or dataset from the hub into the shared cache "
                    "(then pass hf://ORG/NAME[@REV] to --prior, --checkpoint or --data)"),
}

# A user's mistake (a missing folder, a corrupt file, an unknown name, a bad value, a server that is not there)
# raises one of these with a message that says what to fix; anything else is a bug and keeps its traceback.
USER_ERRORS = (ValueError, FileNotFoundError, NotADirectoryError, IsADirectoryError, PermissionError, KeyError,
               ConnectionError, PluginError, CheckpointError)


class CommandExit(SystemExit):
    """Exit status 2 after an ``error: ...`` line; ``str()`` is the message (what tests match)."""

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.code = 2


def _message(err: BaseException) -> str:
    if isinstance(err, KeyError) and err.args:
        return str(err.args[0])
    return str(err)


def _global_options(argv: list[str]) -> tuple[list[str], list[str], bool]:
    """(argv without them, --plugin modules, --debug), wherever on the line they stand."""
    rest, plugins, debug, i = [], [], False, 0
    while i < len(argv):
        arg = argv[i]
        if arg == "--debug":
            debug = True
        elif arg == "--plugin" and i + 1 < len(argv):
            plugins.append(argv[i + 1])
            i += 1
        elif arg.startswith("--plugin="):
            plugins.append(arg.split("=", 1)[1])
        else:
            rest.append(arg)
        i += 1
    return rest, plugins, debug


def _options_type(fn: Any) -> type:
    hints = typing.get_type_hints(fn)
    hints.pop("return", None)
    (cls,) = hints.values()
    return cls


def _config_file_default(cls: type, argv: list[str]) -> tuple[Any, list[str]]:
    """The options in ``--config FILE`` (flags then override them) and the argv without it."""
    if "--config" not in argv and not any(a.startswith("--config=") for a in argv):
        return None, argv
    rest, path, i = [], None, 0
    while i < len(argv):
        if argv[i] == "--config" and i + 1 < len(argv):
            path, i = argv[i + 1], i + 2
            continue
        if argv[i].startswith("--config="):
            path = argv[i].split("=", 1)[1]
        else:
            rest.append(argv[i])
        i += 1
    if path is None:
        raise ValueError("--config needs a file: --config path/to/config.json")
    if not Path(path).is_file():
        raise FileNotFoundError(f"config file {path} does not exist")
    return config_from_dict(cls, read_json_file(path), path, ignore_unknown=False), rest


def parse_command(name: str, argv: list[str]) -> tuple[Callable[[Any], None], Any]:
    """The function a command line runs and its parsed options (nothing runs yet)."""
    from bimanualshift.cli.parsing import parse

    if name not in COMMANDS:
        raise ValueError(f"unknown command {name!r}; `bimanualshift --help` lists them: {', '.join(COMMANDS)}")
    command = COMMANDS[name]
    while command.subcommands:
        choices = ", ".join(command.subcommands)
        if not argv or argv[0] in ("-h", "--help"):
            print(f"usage: bimanualshift {name} {{{choices}}} ...\n\n{command.help}")
            raise SystemExit(0 if argv else 2)
        if argv[0] not in command.subcommands:
            raise ValueError(f"unknown sub-command {argv[0]!r} of `bimanualshift {name}`; choose from {choices}")
        name, command, argv = f"{name} {argv[0]}", command.subcommands[argv[0]], argv[1:]
    module, _, func = command.target.partition(":")
    fn = getattr(importlib.import_module(f"bimanualshift.cli.{module}"), func)
    cls = _options_type(fn)
    default = None
    if command.config_file:
        default, argv = _config_file_default(cls, argv)
    description = command.help + (" Options can come from --config FILE.json (e.g. a run's saved config.json); "
                                  "flags override it." if command.config_file else "")
    return fn, parse(cls, argv, f"bimanualshift {name}", description, default)


def run(parser: argparse.ArgumentParser, argv: list[str]) -> None:
    argv, plugins, debug = _global_options(argv)
    if not argv or argv[0] in ("-h", "--help"):
        parser.print_help()
        raise SystemExit(0 if argv else 2)
    name, rest = argv[0], argv[1:]
    slow_bars_in_logs(is_terminal=sys.stderr.isatty())
    try:
        with quiet_on_closed_pipe():  # `bimanualshift explain ... | head`
            if plugins:
                add_plugins(plugins)
            fn, options = parse_command(name, rest)
            fn(options)
    except USER_ERRORS as err:
        if debug:
            raise
        message = _message(err)
        message = message[len("error: "):] if message.startswith("error: ") else message
        print(f"error: {message}  (--debug shows the traceback)", file=sys.stderr)
        raise CommandExit(message) from None
