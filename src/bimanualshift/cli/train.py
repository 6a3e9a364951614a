"""Commands that train: a single-arm prior, the residual branch, refinement; and shipping a trained prior."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import tyro

from bimanualshift.training.configs import PretrainConfig, RefineConfig, TrainConfig


def pretrain(cfg: PretrainConfig) -> None:
    from bimanualshift.training.pretrain import pretrain as run_pretraining

    print(f"best prior checkpoint: {run_pretraining(cfg)}")


def train(cfg: TrainConfig) -> None:
    from bimanualshift.training.residual_trainer import train_residual

    print(f"best BimanualShift checkpoint: {train_residual(cfg)}")


def refine(cfg: RefineConfig) -> None:
    from bimanualshift.training.refine import refine as run_refinement

    print(f"refined BimanualShift checkpoint: {run_refinement(cfg)}")


@dataclass
class ShipPriorArgs:
    # the best/ folder of a `pretrain` run
    source: Annotated[str, tyro.conf.Positional, tyro.conf.arg(metavar="SOURCE")]
    # the name it loads by, e.g. peract_suite
    name: Annotated[str, tyro.conf.Positional, tyro.conf.arg(metavar="NAME")]
    # the result file under results/ whose table the card shows (`prior-report --out results/NAME.json`)
    results: str = "priors"


def ship_prior(args: ShipPriorArgs) -> None:
    from bimanualshift.priors.shipping import ship_prior as ship

    print(f"shipped {ship(args.source, args.name, results=args.results)}")
