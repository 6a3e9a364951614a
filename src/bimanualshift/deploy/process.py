"""`bimanualshift serve` in a child process, for benchmarks and scripted checks: started, waited for, stopped."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def health(port: int, timeout_s: float = 2.0) -> dict | None:
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/healthz", timeout=timeout_s) as response:
            return json.loads(response.read())
    except (urllib.error.URLError, OSError, ValueError):
        return None


class ServerProcess:
    """``bimanualshift serve ARGS --port PORT`` as a child; ``alive`` tells whether it still runs."""

    def __init__(self, args: list[str], port: int | None = None, log: str | Path | None = None,
                 threads: int | None = None, startup_s: float = 180.0) -> None:
        self.port = port or free_port()
        env = dict(os.environ)
        if threads:
            env["OMP_NUM_THREADS"] = str(threads)
        out = open(log, "w") if log else subprocess.DEVNULL  # noqa: SIM115 - closed in stop()
        self._log = out
        self.proc = subprocess.Popen([sys.executable, "-m", "bimanualshift.cli", "serve", *args,
                                      "--port", str(self.port)], stdout=out, stderr=subprocess.STDOUT, env=env)
        deadline = time.time() + startup_s
        while health(self.port) is None:
            if self.proc.poll() is not None:
                raise RuntimeError(f"bimanualshift serve exited with status {self.proc.returncode} (see {log})")
            if time.time() > deadline:
                self.stop()
                raise RuntimeError(f"bimanualshift serve did not answer within {startup_s:g} s")
            time.sleep(0.5)

    @property
    def alive(self) -> bool:
        return self.proc.poll() is None and health(self.port) is not None

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
        if hasattr(self._log, "close"):
            self._log.close()
