"""One episode, one outcome: the same checkpoint, task and seed give the same outcome and bit-identical actions
through `eval` on 1 and on 2 torch threads, `bench` with 1 and with 2 workers, and `serve` + `deploy --robot sim`.

Before every policy forward pass ran on one intra-op thread (core/threads.py), `eval` on 2 threads executed other
actions than the benchmark's single-threaded workers on these seeds (a few 1e-8 apart, enough to change an outcome
elsewhere)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
import torch

from bimanualshift.cli.evaluate import EvalArgs, evaluate
from bimanualshift.data.seeds import split_seeds
from bimanualshift.deploy.client import PolicyClient
from bimanualshift.deploy.loop import deploy_sim
from bimanualshift.deploy.process import ServerProcess
from bimanualshift.evaluation.bench import BenchConfig, read_episodes, run_bench

pytestmark = pytest.mark.slow

PRIOR, METHOD, TASK, EPISODES, CAP = "peract_suite_v2", "frozen_prior_per_arm", "push_two_buttons", 2, 3


@contextmanager
def torch_threads(n: int) -> Iterator[None]:
    before = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def outcomes(episodes: list[dict]) -> dict[int, tuple[bool, int, str]]:
    return {int(e["seed"]): (bool(e["success"]), int(e["keyframes"]), e["actions_sha256"]) for e in episodes}


def eval_outcomes(tmp_path: Path, threads: int) -> dict[int, tuple[bool, int, str]]:
    out = tmp_path / f"eval_{threads}.json"
    with torch_threads(threads):
        evaluate(EvalArgs(method=METHOD, prior=PRIOR, task=[TASK], episodes=EPISODES, max_keyframes=CAP, out=str(out)))
    result = json.loads(out.read_text())
    assert result["threads"]["policy_forward"] == 1
    return outcomes(result["episodes"])


def bench_outcomes(tmp_path: Path, workers: int) -> dict[int, tuple[bool, int, str]]:
    cfg = BenchConfig(tasks=[TASK], methods=[METHOD], prior=PRIOR, demos=1, validation_demos=1, episodes=EPISODES,
                      workers=workers, videos=0, max_keyframes=CAP, data=str(tmp_path / "data"),
                      runs=str(tmp_path / f"runs_{workers}"), out=str(tmp_path / f"bench_{workers}"))
    run_bench(cfg, command="test")
    return outcomes(read_episodes(tmp_path / f"bench_{workers}" / "episodes.jsonl"))


def deploy_outcomes() -> dict[int, tuple[bool, int, str]]:
    server = ServerProcess(["--prior", PRIOR, "--method", METHOD], threads=2)  # the host's cores, not one
    client = PolicyClient(f"ws://127.0.0.1:{server.port}")
    try:
        records = deploy_sim(TASK, client, split_seeds("test", EPISODES), max_keyframes=CAP)
    finally:
        client.close()
        server.stop()
    assert all(r.aborted is None for r in records)
    return {r.seed: (r.success, r.keyframes, r.actions_sha256) for r in records}


def test_eval_bench_and_deploy_give_one_outcome_and_the_same_actions_per_seed(tmp_path: Path) -> None:
    reference = eval_outcomes(tmp_path, threads=1)
    assert sorted(reference) == split_seeds("test", EPISODES) and all(d for _, _, d in reference.values())
    assert eval_outcomes(tmp_path, threads=2) == reference, "eval on 2 threads"
    assert bench_outcomes(tmp_path, workers=1) == reference, "bench with 1 worker"
    assert bench_outcomes(tmp_path, workers=2) == reference, "bench with 2 workers"
    assert deploy_outcomes() == reference, "serve + deploy --robot sim"


def test_a_trained_bimanualshift_checkpoint_gives_one_outcome_through_eval_workers_and_the_server(
        demo_root: Path, tmp_path: Path) -> None:
    """The method itself (prior per arm through the projection, retrieval, Manager and G), trained for two steps
    on the shipped prior: `eval` on 1 and 2 threads, the benchmark's episode function in 2 spawned workers and
    `serve` + `deploy` execute bit-identical actions."""
    from bimanualshift.evaluation.bench import BenchJob, run_bench_episode
    from bimanualshift.training.configs import TrainConfig
    from bimanualshift.training.request import TrainRequest
    from bimanualshift.training.residual_trainer import train_residual
    from bimanualshift.utils.config_files import config_from_flat
    from bimanualshift.utils.workers import run_jobs

    best = train_residual(config_from_flat(
        TrainConfig, prior=PRIOR, data=str(demo_root / "bimanual"), validation_data=str(demo_root / "bimanual"),
        out=str(tmp_path / "run"), steps=2, checkpoint_every=2, demos=2, retrieval=True, retrieval_threshold=-1.0))
    seeds = split_seeds("test", EPISODES)

    def evaluated(threads: int) -> dict[int, tuple[bool, int, str]]:
        out = tmp_path / f"eval_{threads}.json"
        with torch_threads(threads):
            evaluate(EvalArgs(method="bimanualshift", checkpoint=str(best), task=[TASK], episodes=EPISODES,
                              max_keyframes=CAP, out=str(out)))
        return outcomes(json.loads(out.read_text())["episodes"])

    reference = evaluated(1)
    assert evaluated(2) == reference, "eval on 2 threads"
    request = TrainRequest(task=TASK, data="", validation_data="", demos=2, prior=PRIOR, out=str(best.parent),
                           steps=2)
    jobs = [BenchJob("bimanualshift", TASK, seed, str(best), request.__dict__, max_keyframes=CAP) for seed in seeds]
    assert outcomes(run_jobs(run_bench_episode, jobs, workers=2, chunksize=1)) == reference, "2 benchmark workers"
    server = ServerProcess(["--checkpoint", str(best), "--method", "bimanualshift"], threads=2)
    client = PolicyClient(f"ws://127.0.0.1:{server.port}")
    try:
        records = deploy_sim(TASK, client, seeds, max_keyframes=CAP)
    finally:
        client.close()
        server.stop()
    assert {r.seed: (r.success, r.keyframes, r.actions_sha256) for r in records} == reference, "serve + deploy"
