"""What the residual's training costs with the paper's augmentation (results/residual_cost.json): the frozen
prior run once per (keyframe, arm, augmented copy) to build the cached pool, then each optimisation step.

    .venv/bin/python benchmarks/residual_cost.py --prior peract_suite_v2 --task push_two_buttons --demos 10

Run it on an idle machine. The CPU-hour budget of the studies (docs/benchmark.md) is computed from these figures.
"""

from __future__ import annotations

import argparse
import tempfile
import time

import torch

from bimanualshift.data.collect import collect
from bimanualshift.data.episode import list_episodes
from bimanualshift.data.seeds import split_seeds
from bimanualshift.encoders.text import default_text_encoder, make_text_encoder
from bimanualshift.evaluation.report import invoked_command, write_result
from bimanualshift.methods.prior_step import FrozenPriorStep
from bimanualshift.priors import UnimanualPrior
from bimanualshift.residual.manager import ResidualPolicy
from bimanualshift.residual.skills import SkillBasis
from bimanualshift.training.augment import Se3Augmentation
from bimanualshift.training.configs import ResidualModelConfig, TrainConfig
from bimanualshift.training.optim import make_optimizer
from bimanualshift.training.residual_data import residual_data
from bimanualshift.training.residual_losses import LossWeights, bc_loss
from bimanualshift.utils.pipes import quiet_on_closed_pipe


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--prior", default="peract_suite_v2")
    parser.add_argument("--task", default="push_two_buttons")
    parser.add_argument("--demos", type=int, default=10)
    parser.add_argument("--copies", type=int, default=TrainConfig().dataset.augment_copies)
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--out", default="results/residual_cost.json")
    args = parser.parse_args()
    started = time.time()
    torch.set_num_threads(2)
    with tempfile.TemporaryDirectory() as tmp:
        collect([args.task], split_seeds("train", args.demos), tmp)
        paths = list_episodes(tmp, args.task)
        prior = UnimanualPrior.from_pretrained(args.prior)
        step = FrozenPriorStep(prior, default_text_encoder(), proposal_features=True)
        encoder = make_text_encoder("minilm")
        rcfg = ResidualModelConfig().residual_config(prior.feature_dim, encoder.dim, prior.proposal_feature_dim)
        cfg = TrainConfig().dataset
        t0 = time.perf_counter()
        data = residual_data(rcfg, paths, step, encoder, "prior outputs", Se3Augmentation(
            cfg.augment_translation_m, cfg.augment_yaw_deg), args.copies, seed=0)
        pool_s = time.perf_counter() - t0
    samples = len(data)
    residual = ResidualPolicy(rcfg, SkillBasis.from_verbs(encoder))
    residual.fit_normalisation(data.inputs)
    optimizer = make_optimizer("lamb", residual.parameters(), lr=5e-4)
    gen = torch.Generator().manual_seed(0)
    t0 = time.perf_counter()
    for _ in range(args.steps):
        batch = data.rows(torch.randint(len(data), (4,), generator=gen))
        loss = bc_loss(residual(batch.inputs), batch, LossWeights())["total"]
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    step_ms = 1e3 * (time.perf_counter() - t0) / args.steps
    rows = [{"what": "cached pool: prior outputs of every (keyframe, arm, copy)", "demos": args.demos,
             "copies": 1 + args.copies, "samples": samples, "seconds": round(pool_s, 1),
             "ms_per_sample": round(1e3 * pool_s / samples, 1)},
            {"what": "residual optimisation step (batch 4, LAMB)", "steps": args.steps,
             "ms_per_step": round(step_ms, 2)}]
    for row in rows:
        print(row)
    write_result(args.out, invoked_command(), {"train": split_seeds(
        "train", args.demos)}, started, rows, notes="2 torch threads, idle machine; the pool includes voxelising "
        "the demos' keyframes (the projection) and the prior's forward pass on each augmented copy")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with quiet_on_closed_pipe():
        main()
