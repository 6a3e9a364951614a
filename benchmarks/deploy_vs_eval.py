"""Deployment through the policy server against the offline evaluation, seed for seed
(results/deploy_vs_eval.json).

    .venv/bin/python benchmarks/deploy_vs_eval.py --episodes 20 --out results/deploy_vs_eval.json \
        [--checkpoint runs/<run>/best | --prior peract_suite --method no_residual]

`bimanualshift serve` runs in its own process; the MuJoCo robot sends every observation through the codec and
executes the replies (`bimanualshift deploy --robot sim`). The same checkpoint is evaluated offline in this
process (`bimanualshift eval`: the rollout loop calling the policy directly). Per task and seed: success both
ways, and whether every executed keyframe action is bit-identical.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from bimanualshift.data.seeds import split_seeds
from bimanualshift.deploy.client import PolicyClient
from bimanualshift.deploy.loop import deploy_sim
from bimanualshift.deploy.process import ServerProcess
from bimanualshift.deploy.served_policy import load_served_policy
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.rollout.loop import episode_budget, rollout
from bimanualshift.sim.env import ManipulationEnv
from bimanualshift.sim.task_registry import resolve_task_names
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def offline(policy, task: str, seeds: list[int]) -> list[tuple[bool, list]]:  # noqa: ANN001 - any policy
    env = ManipulationEnv(task)
    out = []
    for seed in seeds:
        executed: list = []

        def act(k: int, frame: object, executed: list = executed) -> np.ndarray:
            executed.append(np.asarray(policy.act(frame), np.float32).tolist())
            return np.asarray(executed[-1], np.float32)

        policy.reset()
        record = rollout(env, policy, seed, episode_budget(env, seed), act=act)
        out.append((record.success, executed))
    env.close()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--checkpoint", default="")
    parser.add_argument("--prior", default="peract_suite")
    parser.add_argument("--method", default="no_residual")
    parser.add_argument("--task", nargs="+", default=["bimanual"])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--split", default="test")
    parser.add_argument("--out", default="results/deploy_vs_eval.json")
    args = parser.parse_args()
    started = time.time()
    serve_args = ["--checkpoint", args.checkpoint, "--method", args.method] if args.checkpoint else [
        "--prior", args.prior, "--method", args.method]
    server = ServerProcess(serve_args, threads=1)
    client = PolicyClient(f"ws://127.0.0.1:{server.port}")
    served = load_served_policy(args.method, args.checkpoint, "" if args.checkpoint else args.prior)
    seeds = split_seeds(args.split, args.episodes)
    rows = []
    try:
        for task in resolve_task_names(args.task):
            deployed = deploy_sim(task, client, seeds)
            reference = offline(served.policy, task, seeds)
            for record, (success, executed) in zip(deployed, reference):
                rows.append({"task": task, "seed": record.seed, "deploy_success": record.success,
                             "eval_success": success, "same_success": record.success == success,
                             "keyframes": record.keyframes, "same_actions": record.executed == executed,
                             "aborted": record.aborted})
            same = sum(r["same_success"] for r in rows if r["task"] == task)
            print(f"{task}: same success on {same}/{len(seeds)} seeds; deploy {sum(r.success for r in deployed)}, "
                  f"eval {sum(s for s, _ in reference)}")
    finally:
        client.close()
        server.stop()
    identical = all(r["same_success"] and r["same_actions"] for r in rows)
    print(f"identical success and actions on every seed: {identical}")
    write_result(args.out, invoked_command(), {args.split: seeds}, started,
                 rows, notes=f"server: bimanualshift serve {' '.join(serve_args)} (own process); robot: the MuJoCo "
                 "robot, every observation and action through the msgpack codec", identical=identical,
                 episodes_per_task=args.episodes)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
