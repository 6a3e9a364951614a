"""Data-parallel training across processes (several GPUs or nodes), launched by ``torchrun``.

``torchrun --nproc_per_node N -m bimanualshift.cli pretrain ...`` starts N copies; each reads its rank from the
environment ``torchrun`` sets (``RANK``, ``WORLD_SIZE``, ``LOCAL_RANK``, ``MASTER_ADDR``/``PORT``). A run's batch
size is the **global** batch: every rank draws the same batch from the step's generator (with its augmentation),
keeps its own slice of it, and DDP averages the gradients, so N processes follow the loss curve of one process at
that batch (to float tolerance, for losses that draw no random numbers of their own). Only rank 0 writes
checkpoints, validation and the best model; every rank resumes from the same newest checkpoint.
"""

from __future__ import annotations

import atexit
import os
from dataclasses import dataclass

import torch
import torch.distributed as dist
from torch import nn


@dataclass(frozen=True)
class Distributed:
    rank: int = 0
    world_size: int = 1

    @property
    def is_main(self) -> bool:
        return self.rank == 0

    @property
    def enabled(self) -> bool:
        return self.world_size > 1

    def shard(self, batch_size: int, index: torch.Tensor) -> torch.Tensor:
        """Positions within a global batch of ``batch_size`` that this rank trains on (a contiguous slice)."""
        if batch_size % self.world_size:
            raise ValueError(f"the batch size {batch_size} must be a multiple of the {self.world_size} processes "
                             "(it is the global batch, split evenly across them)")
        per_rank = batch_size // self.world_size
        return index[self.rank * per_rank:(self.rank + 1) * per_rank]

    def mean(self, value: torch.Tensor) -> torch.Tensor:
        """The mean of ``value`` over every rank (what one process at the global batch would log)."""
        if not self.enabled:
            return value
        out = value.detach().clone()
        dist.all_reduce(out)
        return out / self.world_size

    def barrier(self) -> None:
        if self.enabled:
            dist.barrier()


def init_distributed() -> Distributed:
    """The process group ``torchrun`` asked for (gloo on CPU, NCCL on GPUs), or a single process."""
    world_size = int(os.environ.get("WORLD_SIZE", "1"))
    if world_size <= 1:
        return Distributed()
    if not dist.is_initialized():
        backend = "nccl" if torch.cuda.is_available() else "gloo"
        if backend == "nccl":
            torch.cuda.set_device(int(os.environ.get("LOCAL_RANK", "0")))
        dist.init_process_group(backend=backend)
        # Gloo's worker threads must stop while the interpreter is still whole: a process that exits with the
        # group up can abort in its teardown ("terminate called without an active exception").
        atexit.register(_destroy_process_group)
    return Distributed(dist.get_rank(), dist.get_world_size())


def _destroy_process_group() -> None:
    if dist.is_initialized():
        dist.destroy_process_group()


class LossModule(nn.Module):
    """A model's ``compute_loss`` as a ``forward``, so DDP can wrap it (DDP syncs gradients of what forward ran)."""

    def __init__(self, model: nn.Module) -> None:
        super().__init__()
        self.model = model

    def forward(self, inputs: tuple[torch.Tensor, ...], actions: dict[str, torch.Tensor],
                generator: torch.Generator) -> dict[str, torch.Tensor]:
        return self.model.compute_loss(inputs, actions, generator)  # type: ignore[operator]


def loss_module(model: nn.Module, ctx: Distributed) -> nn.Module:
    """``model``'s loss, gradient-averaged across ranks when there are several."""
    module = LossModule(model)
    if not ctx.enabled:
        return module
    from torch.nn.parallel import DistributedDataParallel

    return DistributedDataParallel(module, find_unused_parameters=True)
