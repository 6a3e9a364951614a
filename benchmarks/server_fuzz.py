"""Send a corpus of malformed requests to `bimanualshift serve` and check every reply (results/server_fuzz.json).

    .venv/bin/python benchmarks/server_fuzz.py --per-class 100 --out results/server_fuzz.json

The server runs in its own process (a crash is the process dying or refusing connections), serving the shipped
frozen prior on a real push_two_buttons observation. Every case (``deploy.malformed``: fourteen classes,
``per-class`` each) goes over one authenticated connection; a wrong-token case opens its own connection. A case
passes when the reply is a structured error (a JSON text frame with code, field and message; for a wrong token an
HTTP 401 at the handshake) and a valid request on the same connection right after it is served. A token-file case
starts another `bimanualshift serve` on 0.0.0.0 with a token file of that mode: it passes when the command refuses
to start, says `chmod 600` and prints no traceback.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from tqdm import tqdm

from bimanualshift.deploy.client import PolicyClient, ServerUnavailable
from bimanualshift.deploy.malformed import CLASSES, corpus
from bimanualshift.deploy.process import ServerProcess
from bimanualshift.deploy.sim_robot import first_observation_message
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def refused_token_file(tmp: Path, token: str, mode: int | None, prior: str) -> str:
    """'' when `serve` with a token file of ``mode`` refuses to start with a clear message, else the problem."""
    path = tmp / f"token_{mode:o}"
    path.write_text(token)
    path.chmod(mode or 0)
    try:
        done = subprocess.run([sys.executable, "-m", "bimanualshift.cli", "serve", "--prior", prior, "--method",
                               "no_residual", "--host", "0.0.0.0", "--port", "0", "--token-file", str(path)],
                              capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        return "serve started and served"
    finally:
        path.chmod(0o600)
        path.unlink()
    said = done.stdout + done.stderr
    if done.returncode == 0:
        return "serve started"
    if "Traceback (most recent call last)" in said or "chmod 600" not in said:
        return f"unclear refusal: {said.strip()[-200:]}"
    return ""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--per-class", type=int, default=100)
    parser.add_argument("--prior", default="peract_suite")
    parser.add_argument("--limit-mb", type=float, default=2.0, help="the server's --max-message-mb")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="results/server_fuzz.json")
    args = parser.parse_args()
    started = time.time()

    valid = first_observation_message("push_two_buttons", 0, "fuzz")
    limit = int(args.limit_mb * 2**20)
    token = "fuzz-token-" + "x" * 24
    with tempfile.TemporaryDirectory() as tmp:
        token_file = Path(tmp) / "token"
        token_file.write_text(token)
        token_file.chmod(0o600)
        server = ServerProcess(["--prior", args.prior, "--method", "no_residual", "--token-file", str(token_file),
                                "--max-message-mb", str(args.limit_mb)], log=Path(tmp) / "serve.log")
        url = f"ws://127.0.0.1:{server.port}"
        client = PolicyClient(url, token)
        counts: Counter[str] = Counter()
        passed: Counter[str] = Counter()
        failures: list[dict[str, str]] = []
        crashes = 0
        cases = list(corpus(valid, args.per_class, limit, token, args.seed))
        for i, case in enumerate(tqdm(cases, desc="fuzz", unit="case")):
            counts[case.kind] += 1
            problem = ""
            try:
                if case.kind == "token_file_mode":
                    problem = refused_token_file(Path(tmp), token, case.mode, args.prior)
                elif case.kind == "wrong_token":
                    try:
                        PolicyClient(url, case.token, retries=0)
                        problem = "a wrong key was accepted"
                    except ServerUnavailable as err:
                        problem = "" if "HTTP 401" in str(err) else f"not refused with 401: {err}"
                else:
                    client._ws.send(case.frame)
                    reply = client._ws.recv(timeout=60)
                    if not isinstance(reply, str):
                        problem = "answered with an action"
                    else:
                        error = json.loads(reply).get("error", {})
                        if not all(error.get(k) for k in ("code", "field", "message")) or "Traceback" in reply:
                            problem = f"unstructured error: {reply[:200]}"
                valid["keyframe"] = i % 20 + 1
                if client.infer(valid)["action"].shape != (2, 9):
                    problem = problem or "the valid request after it was not served"
            except Exception as err:  # the connection or the server died: a crash
                problem = f"{type(err).__name__}: {err}"
                if not server.alive:
                    crashes += 1
                    failures.append({"class": case.kind, "case": case.description, "problem": "server died"})
                    break
                client = PolicyClient(url, token)
            if problem:
                failures.append({"class": case.kind, "case": case.description, "problem": problem})
            else:
                passed[case.kind] += 1
        alive = server.alive
        server.stop()

    rows = [{"class": kind, "cases": counts[kind], "structured_errors_then_served": passed[kind],
             "failures": counts[kind] - passed[kind]} for kind in CLASSES]
    total = sum(counts.values())
    print(f"{total} cases, {sum(passed.values())} passed, {len(failures)} failures, {crashes} crashes, "
          f"server alive at the end: {alive}")
    for row in rows:
        print(f"  {row['class']:16s} {row['cases']:5d} cases, {row['failures']} failures")
    write_result(args.out, invoked_command(), {"corpus": [args.seed]}, started,
                 rows, notes="one server process (bimanualshift serve, the frozen prior on a real push_two_buttons "
                 "observation); each case then a valid request on the same connection",
                 cases=total, crashes=crashes, server_alive_at_end=alive, failures=failures[:50],
                 limit_bytes=limit)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
