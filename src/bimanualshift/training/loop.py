"""A small, resumable training loop shared by prior pretraining and residual training.

Every ``checkpoint_every`` steps the model, optimiser and RNG state are saved atomically; starting again
with the same run directory resumes from the newest checkpoint. Batches are drawn from a generator
seeded by (seed, step), so a resumed run sees exactly the batches an uninterrupted run would have seen.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import torch
from torch import nn
from tqdm import tqdm

from bimanualshift.training.checkpoint import latest_checkpoint, load_checkpoint, save_checkpoint
from bimanualshift.training.distributed import Distributed
from bimanualshift.training.metric_log import MetricLogger
from bimanualshift.utils.io import atomic_write_json

StepFn = Callable[[int, torch.Generator], dict[str, torch.Tensor]]
# Lower is better; a dict gives the value under "value" and further figures to log beside it (e.g. median errors).
ValidateFn = Callable[[int], "float | dict[str, float]"]


def _validation(validate_fn: ValidateFn, step: int) -> tuple[float, dict[str, float]]:
    result = validate_fn(step)
    if isinstance(result, dict):
        return float(result["value"]), {f"validation_{k}": v for k, v in result.items() if k != "value"}
    return float(result), {}


def _validation_scalars(record: dict[str, Any]) -> dict[str, Any]:
    """A checkpoint record's validation figures, named for the logger (validation/value, validation/<detail>)."""
    figures = {k.removeprefix("validation_"): v for k, v in record.items() if k.startswith("validation_")}
    value = {"value": record["validation"]} if "validation" in record else {}
    return {"validation": {**value, **figures}, "train": {"elapsed_s": record.get("elapsed_s")}}


def step_generator(seed: int, step: int) -> torch.Generator:
    return torch.Generator().manual_seed(seed * 1_000_003 + step)


def run_training(run_dir: str | Path, model: nn.Module, optimizer: torch.optim.Optimizer, steps: int,
                 step_fn: StepFn, seed: int, checkpoint_every: int = 100,
                 validate_fn: ValidateFn | None = None, on_best: Callable[[int, float, float], None] | None = None,
                 desc: str = "train", ctx: Distributed | None = None,
                 lr_factor: Callable[[int], float] | None = None, patience: int = 0,
                 logger: MetricLogger | None = None,
                 on_validated: Callable[[int, float], None] | None = None) -> dict[str, Any]:
    """Train for ``steps``; with ``ctx`` (several ``torchrun`` processes) every rank steps, losses are logged as
    their mean over the ranks, and only rank 0 validates and writes. ``lr_factor(step)`` scales every parameter
    group's learning rate at each step (a schedule; computed from the step, so resuming continues it).
    ``patience`` > 0 (one process only) stops early once that many checkpoints in a row have not improved on the
    best validation value; a resumed run that had stopped stays stopped. ``logger`` (rank 0) receives every step's
    loss terms, learning rate and step time, and every checkpoint's validation figures. ``on_validated(step,
    value)`` sees every validated checkpoint, the untrained one included (the closed-loop choice keeps candidates)."""
    if patience and ctx is not None and ctx.enabled:
        raise ValueError("early stopping (patience) runs in one process; use patience 0 under torchrun")
    ctx = ctx or Distributed()
    logger = logger if logger is not None and ctx.is_main else MetricLogger()
    base_lr = [group["lr"] for group in optimizer.param_groups]
    run_dir = Path(run_dir)
    start, history, best = 0, [], {"step": None, "value": float("inf")}
    elapsed_before = 0.0  # training seconds spent by earlier, interrupted runs of this directory
    ckpt = latest_checkpoint(run_dir)
    if ckpt is not None:
        state = load_checkpoint(ckpt, model, optimizer)
        start, history, best = state["step"], state.get("history", []), state.get("best", best)
        elapsed_before = float(state.get("elapsed_s", 0.0))
    resumed_at = time.time()
    if start == 0 and validate_fn is not None and ctx.is_main:
        # The untrained model is a candidate too: a residual branch that starts as the identity must beat
        # the frozen prior alone on validation data before a trained checkpoint replaces it.
        model.eval()
        value, details = _validation(validate_fn, 0)
        best = {"step": 0, "value": value}
        history.append({"step": 0, "elapsed_s": 0.0, "validation": value, **details})
        logger.scalars(0, _validation_scalars(history[-1]))
        if on_best is not None:
            on_best(0, best["value"], 0.0)
        if on_validated is not None:
            on_validated(0, value)
    bar = tqdm(range(start, steps), initial=start, total=steps, desc=desc, unit="step", disable=not ctx.is_main)
    # Losses are logged as their mean over the steps since the last checkpoint (one batch's value is too noisy
    # to tell a stage that learns from one that does not); the sums restart at every checkpoint, so a resumed
    # run logs what an uninterrupted one would.
    sums: dict[str, float] = {}
    counted = 0

    def exhausted() -> bool:
        return bool(patience and validate_fn is not None and best["step"] is not None and history
                    and history[-1]["step"] - best["step"] >= patience * checkpoint_every)

    stopped_at = history[-1]["step"] if exhausted() else None
    for step in (() if stopped_at is not None else bar):
        step_started = time.perf_counter()
        model.train()
        if lr_factor is not None:
            for group, lr in zip(optimizer.param_groups, base_lr):
                group["lr"] = lr * lr_factor(step)
        losses = step_fn(step, step_generator(seed, step))
        optimizer.zero_grad(set_to_none=True)
        losses["total"].backward()
        optimizer.step()
        logged = {k: float(ctx.mean(v.detach())) for k, v in losses.items()}
        for k, v in logged.items():
            sums[k] = sums.get(k, 0.0) + v
        counted += 1
        logger.scalars(step + 1, {"loss": logged, "train": {"lr": optimizer.param_groups[0]["lr"],
                                                            "step_time_s": time.perf_counter() - step_started}})
        bar.set_postfix(loss=round(logged["total"], 4), refresh=False)  # shown at the next timed redraw
        done = step + 1
        at_checkpoint = done % checkpoint_every == 0 or done == steps
        if at_checkpoint:
            means = {k: round(v / counted, 5) for k, v in sums.items()}
            sums, counted = {}, 0
        if at_checkpoint and ctx.is_main:
            elapsed = round(elapsed_before + time.time() - resumed_at, 1)
            record: dict[str, Any] = {"step": done, "elapsed_s": elapsed, **means}
            if validate_fn is not None:
                model.eval()
                value, details = _validation(validate_fn, done)
                record["validation"] = value
                record.update(details)
                if value < best["value"]:
                    best = {"step": done, "value": value}
                    if on_best is not None:
                        on_best(done, value, elapsed)
                if on_validated is not None:
                    on_validated(done, value)
            history.append(record)
            logger.scalars(done, _validation_scalars(record))
            save_checkpoint(run_dir, done, model, optimizer, {"history": history, "best": best, "elapsed_s": elapsed})
            atomic_write_json(run_dir / "history.json", {"history": history, "best": best})
            if exhausted():
                stopped_at = done
                break
    ctx.barrier()  # every rank ends with rank 0's last checkpoint on disk
    # Training time over every invocation of this directory (a resumed run's wall time covers only itself).
    training_time_s = history[-1]["elapsed_s"] if history else round(elapsed_before, 1)
    return {"history": history, "best": best, "training_time_s": training_time_s, "stopped_early_at": stopped_at}
