import math
import os
import time
from pathlib import Path

import pytest

from bimanualshift.utils.workers import run_jobs


def test_jobs_give_the_same_results_in_process_and_in_spawned_workers() -> None:
    jobs = [1.0, 4.0, 9.0, 16.0, 25.0]
    assert run_jobs(math.sqrt, jobs) == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert sorted(run_jobs(math.sqrt, jobs, workers=2)) == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert sorted(run_jobs(math.sqrt, jobs, workers=2, chunksize=3)) == [1.0, 2.0, 3.0, 4.0, 5.0]


def test_a_worker_that_dies_fails_the_run_instead_of_hanging_it() -> None:
    from concurrent.futures.process import BrokenProcessPool

    # os._exit ends the worker process the way an out-of-memory kill or a native crash does
    with pytest.raises(BrokenProcessPool):
        run_jobs(os._exit, [3, 3], workers=2, chunksize=1)


def test_a_job_error_in_a_worker_reaches_the_caller() -> None:
    with pytest.raises(ValueError, match="math domain error"):
        run_jobs(math.sqrt, [4.0, -1.0], workers=2, chunksize=1)


def test_past_the_deadline_queued_jobs_are_dropped() -> None:
    started = time.time()
    # each job sleeps 0.5 s; by the deadline, 4 s on, two workers have finished at most 16 of the 40 and the rest is
    # dropped. The margin lets a loaded machine take up to 3.5 s to start the workers (1.5 s was too tight once)
    done = run_jobs(time.sleep, [0.5] * 40, workers=2, chunksize=1, deadline=started + 4.0)
    assert 1 <= len(done) <= 16
    assert time.time() - started < 9  # the queued 24 or more were dropped, not slept through (10 s on two workers)


def test_job_specs_and_records_cross_as_json() -> None:
    import json

    import numpy as np

    from bimanualshift.evaluation.bench import BenchJob
    from bimanualshift.sim.expert_check import ExpertEpisode
    from bimanualshift.utils.workers import from_json, to_json

    job = BenchJob("bimanualshift", "push_two_buttons", 7, "", {"task": "push_two_buttons", "demos": 3},
                   max_keyframes=4)
    record = ExpertEpisode("lift_ball", 3, True, np.int64(4), 1.5)
    for value in (job, record, ("prior", "task", 9), {"a": [1, (2, 3)]}):
        assert from_json(json.loads(json.dumps(to_json(value)))) == value
    with pytest.raises(TypeError, match="cannot cross"):
        to_json(object())
    with pytest.raises(ValueError, match="only bimanualshift"):
        from_json({"__dataclass__": "subprocess:Popen", "fields": {}})


@pytest.mark.slow
def test_ray_executor_gives_the_local_pool_s_episodes_seed_by_seed(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """The same bench episodes (a frozen prior on a bimanual task) as Ray tasks and in the local pool."""
    import ray

    # Ray's workers run at niceness 15: beside another pytest worker's tests they would get ~3 % of a core
    monkeypatch.setenv("RAY_worker_niceness", "0")

    from bimanualshift.evaluation.bench import BenchJob, run_bench_episode

    request = {"task": "push_two_buttons", "data": "", "validation_data": "", "demos": 1, "prior": "peract_suite",
               "out": str(tmp_path), "steps": 1}
    jobs = [BenchJob("frozen_prior_per_arm", "push_two_buttons", seed, "", request, max_keyframes=3)
            for seed in (200_000, 200_001)]
    local = sorted(run_jobs(run_bench_episode, jobs, workers=1), key=lambda e: e["seed"])  # in this process
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        remote = sorted(run_jobs(run_bench_episode, jobs, executor="ray"), key=lambda e: e["seed"])
    finally:
        ray.shutdown()
    assert remote == local
    assert [e["seed"] for e in remote] == [200_000, 200_001]
