"""Latency and throughput of `bimanualshift serve` on loopback, 1 and 8 concurrent clients
(results/server_latency.json).

    .venv/bin/python benchmarks/server_latency.py --requests 40 --out results/server_latency.json

The server (its own process, two torch threads) serves the shipped frozen prior; each client sends real
push_two_buttons observations (six 128x128 RGB-D cameras with segmentation maps, ~1.1 MB a frame) one after
another. Per setting: round-trip p50/p99 in ms, the server's own inference p50, errors, and throughput in
requests per second. The 8-client throughput is compared with the single-client maximum (target >= 0.9x).
Run it on an otherwise idle machine.
"""

from __future__ import annotations

import argparse
import threading
import time

import numpy as np

from bimanualshift.deploy.client import PolicyClient
from bimanualshift.deploy.process import ServerProcess
from bimanualshift.deploy.sim_robot import first_observation_message
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def run_clients(url: str, message: dict, clients: int, requests: int) -> dict:
    round_trips: list[float] = []
    infer: list[float] = []
    errors = [0]
    lock = threading.Lock()
    barrier = threading.Barrier(clients + 1)

    def worker(c: int) -> None:
        client = PolicyClient(url)
        msg = {**message, "episode_id": f"client-{c}"}
        client.infer({**msg, "keyframe": 0})  # warm the connection's session
        barrier.wait()
        for k in range(requests):
            t0 = time.perf_counter()
            try:
                reply = client.infer({**msg, "keyframe": k + 1})
                with lock:
                    round_trips.append(1e3 * (time.perf_counter() - t0))
                    infer.append(float(reply["timing"]["infer_ms"]))
            except Exception:
                with lock:
                    errors[0] += 1
        client.close()

    threads = [threading.Thread(target=worker, args=(c,)) for c in range(clients)]
    for t in threads:
        t.start()
    barrier.wait()
    t0 = time.perf_counter()
    for t in threads:
        t.join()
    wall = time.perf_counter() - t0
    rt = np.asarray(round_trips)
    return {"clients": clients, "requests": clients * requests, "errors": errors[0],
            "p50_ms": round(float(np.percentile(rt, 50)), 1), "p99_ms": round(float(np.percentile(rt, 99)), 1),
            "server_infer_p50_ms": round(float(np.median(infer)), 1),
            "throughput_rps": round(len(rt) / wall, 3), "wall_s": round(wall, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--prior", default="peract_suite")
    parser.add_argument("--requests", type=int, default=40, help="per client")
    parser.add_argument("--out", default="results/server_latency.json")
    parser.add_argument("--note", default="", help="a remark recorded in the result file (e.g. a before figure)")
    args = parser.parse_args()
    started = time.time()
    message = first_observation_message("push_two_buttons", 0, "latency")
    server = ServerProcess(["--prior", args.prior, "--method", "no_residual"], threads=2)
    url = f"ws://127.0.0.1:{server.port}"
    try:
        single = run_clients(url, message, 1, args.requests)
        eight = run_clients(url, message, 8, max(args.requests // 4, 5))
    finally:
        server.stop()
    ratio = eight["throughput_rps"] / single["throughput_rps"]
    for row in (single, eight):
        print(f"{row['clients']} client(s): p50 {row['p50_ms']} ms, p99 {row['p99_ms']} ms, "
              f"{row['throughput_rps']} req/s, {row['errors']} errors")
    print(f"8-client throughput / single-client: {ratio:.2f} (target >= 0.9)")
    write_result(args.out, invoked_command(), {"observation": [0]}, started,
                 [single, eight], notes="loopback; server process with 2 torch threads serving the frozen prior "
                 "(no_residual: projection + prior per arm); 1.1 MB observation frames; the policy runs one request "
                 "at a time (each op on one thread, the two arms' prior passes side by side), decoding and encoding "
                 "overlap"
                 + (f"; {args.note}" if args.note else ""), throughput_ratio_8_to_1=round(ratio, 3))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
