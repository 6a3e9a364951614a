"""How fast the command line answers: wall time of `bimanualshift --help`, `tasks` and each command's `--help`
in a fresh process (writes results/cli_startup.json).

    .venv/bin/python benchmarks/cli_startup.py --repeats 5

Each row is the median of ``--repeats`` fresh processes (the interpreter's own start included); run it with
nothing else on the machine. Top-level help and `tasks` import nothing heavy; a command's `--help` imports
what its options need (the training commands import torch for their configs).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from bimanualshift.cli.dispatch import COMMANDS
from bimanualshift.evaluation.report import write_result
from bimanualshift.utils.pipes import quiet_on_closed_pipe

BIN = str(Path(sys.executable).with_name("bimanualshift"))


def seconds(argv: list[str], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run([BIN, *argv], check=True, capture_output=True, env={**os.environ, "COLUMNS": "100"})
        times.append(time.perf_counter() - t0)
    return round(statistics.median(times), 3)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--out", default="results/cli_startup.json")
    args = parser.parse_args()
    started = time.time()
    lines = [["--help"], ["tasks"]] + [[name, "--help"] for name, c in COMMANDS.items() if not c.subcommands]
    lines.append(["viz", "projection", "--help"])
    rows = []
    for argv in lines:
        rows.append({"command": "bimanualshift " + " ".join(argv), "wall_time_s": seconds(argv, args.repeats),
                     "repeats": args.repeats})
        print(f"{rows[-1]['command']:44s} {rows[-1]['wall_time_s']:.2f} s")
    write_result(args.out, f"python benchmarks/cli_startup.py --repeats {args.repeats}", {}, started, rows,
                 notes="median wall time of fresh processes, interpreter start included, nothing else running; "
                       "target: `--help` and `tasks` in about a second")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
