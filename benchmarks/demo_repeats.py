"""Run `bimanualshift demo` several times from scratch on this machine and compare what each run trained and
measured (results/demo_repeats.json): is training bit-for-bit reproducible on one host?

    .venv/bin/python benchmarks/demo_repeats.py --runs 3 --out results/demo_repeats.json

Each run gets a fresh work folder (demos collected again, the residual trained from its seed); the shipped prior
is the same file every time. Per run: the SHA-256 of the chosen checkpoint's weights, its step and validation
value, the success of each method and the per-seed outcomes with their action digests. The file also lists the
demo results the repository recorded on other machines, for the spread across hosts.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def one_run(root: Path, i: int) -> dict:
    work, results = root / f"work_{i}", root / f"results_{i}"
    started = time.time()
    subprocess.run([sys.executable, "-m", "bimanualshift.cli", "demo", "--workdir", str(work), "--results",
                    str(results)], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    summary = json.loads((results / "summary.json").read_text())
    return {"run": i, "weights_sha256": sha256(work / "bimanualshift" / "best" / "model.safetensors"),
            "best": summary["residual_training"]["best"],
            "success": {r["method"]: r["success"] for r in summary["rows"]},
            "failed_seeds": {m: [e["seed"] for e in summary["episodes"] if e["method"] == m and not e["success"]]
                             for m in {r["method"] for r in summary["rows"]}},
            "wall_time_s": round(time.time() - started, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--out", default="results/demo_repeats.json")
    parser.add_argument("--note", default="")
    args = parser.parse_args()
    started = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        rows = []
        for i in range(args.runs):
            rows.append(one_run(Path(tmp), i))
            print(f"run {i}: weights {rows[-1]['weights_sha256'][:16]}, best {rows[-1]['best']}, "
                  f"success {rows[-1]['success']}")
    identical = len({r["weights_sha256"] for r in rows}) == 1 and len({json.dumps(r["failed_seeds"], sort_keys=True)
                                                                       for r in rows}) == 1
    print(f"identical weights and per-seed outcomes in all {args.runs} runs: {identical}")
    write_result(args.out, invoked_command(), {"test": list(range(200000, 200020))}, started, rows,
                 notes="each run: `bimanualshift demo` in a fresh work folder on this machine, nothing else running"
                 + (f"; {args.note}" if args.note else ""), identical=identical)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
