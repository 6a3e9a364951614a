"""Training curves for TensorBoard or Weights & Biases (`--log tensorboard|wandb|none`).

Every trainer hands its step's loss terms, learning rate and step time, and each checkpoint's validation figures,
to one ``MetricLogger``. TensorBoard event files go to ``RUN/tensorboard`` (`tensorboard --logdir RUN`); a resumed
run discards the events past its checkpoint, so its curves show each step once. W&B runs offline unless
``WANDB_MODE`` says otherwise (`wandb sync RUN/wandb/offline-run-*` uploads them). Neither library is imported
unless asked for, so `--help` and the default run stay as light as before.
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Literal

LogKind = Literal["none", "tensorboard", "wandb"]
LOG_KINDS = ("none", "tensorboard", "wandb")
TENSORBOARD_DIR = "tensorboard"


class MetricLogger:
    """The no-op logger (``--log none``); the others override ``scalars`` and ``close``."""

    def scalars(self, step: int, values: dict[str, Any]) -> None:
        pass

    def close(self) -> None:
        pass


def numeric(values: dict[str, Any], prefix: str = "") -> dict[str, float]:
    """The finite numbers of ``values`` (nested dicts flattened with '/'), named under ``prefix``."""
    out: dict[str, float] = {}
    for key, value in values.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(numeric(value, f"{name}/"))
        elif isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
            out[name] = float(value)
    return out


class TensorBoardLogger(MetricLogger):
    def __init__(self, run_dir: Path, start_step: int) -> None:
        try:
            from torch.utils.tensorboard import SummaryWriter
        except ImportError as err:
            raise ImportError("--log tensorboard needs the tensorboard package: pip install 'bimanualshift[log]' "
                              "(tensorboard==2.21.0)") from err
        # purge_step: a resumed run first drops the events an interrupted run wrote past its last checkpoint (steps
        # are counted done, so the checkpoint's own step stays)
        self.writer = SummaryWriter(log_dir=str(run_dir / TENSORBOARD_DIR),
                                    purge_step=start_step + 1 if start_step else None)

    def scalars(self, step: int, values: dict[str, Any]) -> None:
        for name, value in numeric(values).items():
            self.writer.add_scalar(name, value, step)

    def close(self) -> None:
        self.writer.close()


class WandbLogger(MetricLogger):
    def __init__(self, run_dir: Path, config: dict[str, Any]) -> None:
        try:
            import wandb
        except ImportError as err:
            raise ImportError("--log wandb needs the wandb package: pip install 'bimanualshift[wandb]' "
                              "(wandb==0.31.0)") from err
        run_id = hashlib.sha1(str(run_dir.resolve()).encode()).hexdigest()[:12]  # one W&B run per run folder
        self.run = wandb.init(project=os.environ.get("WANDB_PROJECT", "bimanualshift"), name=run_dir.name,
                              id=run_id, resume="allow", dir=str(run_dir), config=config,
                              mode=os.environ.get("WANDB_MODE", "offline"))

    def scalars(self, step: int, values: dict[str, Any]) -> None:
        self.run.log(numeric(values), step=step)

    def close(self) -> None:
        self.run.finish()


def make_logger(kind: str, run_dir: str | Path, start_step: int = 0,
                config: dict[str, Any] | None = None) -> MetricLogger:
    if kind not in LOG_KINDS:
        raise ValueError(f"--log {kind!r}: choose one of {', '.join(LOG_KINDS)}")
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    if kind == "tensorboard":
        return TensorBoardLogger(run_dir, start_step)
    if kind == "wandb":
        return WandbLogger(run_dir, config or {})
    return MetricLogger()


@contextmanager
def open_logger(kind: str, run_dir: str | Path, config: dict[str, Any] | None = None) -> Iterator[MetricLogger]:
    """``make_logger`` for the length of a ``with`` block, resuming at the run's newest checkpoint."""
    from bimanualshift.training.checkpoint import checkpoint_step, latest_checkpoint

    latest = latest_checkpoint(run_dir)
    logger = make_logger(kind, run_dir, checkpoint_step(latest) if latest else 0, config)
    try:
        yield logger
    finally:
        logger.close()
