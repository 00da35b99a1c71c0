"""Data-parallel training under ``torchrun``: one process per rank, the same weights on every rank.

    torchrun --nproc_per_node 2 -m gmcpt train --config cpu --out runs/ddp
    torchrun --nnodes 2 --node_rank R --master_addr HEAD --master_port 29500 --nproc_per_node 4 -m gmcpt train ...

``torchrun`` sets ``RANK``, ``WORLD_SIZE`` and ``LOCAL_RANK``; without them
training runs in one process, as it always did. With them (:func:`start`) each
rank joins a process group (``gloo`` on the CPU, ``nccl`` on CUDA, rank ``r``
on GPU ``LOCAL_RANK``), samples crops from its own share of the training
scenes (:func:`shard`) with its own seed, and the gradients are averaged
over the ranks before every optimiser step: the generator is wrapped in
:class:`torch.nn.parallel.DistributedDataParallel`; the critic, whose
gradient penalty differentiates twice (which DDP's gradient hooks do not
support), has its gradients averaged by :func:`average_gradients` instead.
The ranks thus take identical steps from identical initial weights and hold
the same weights throughout (:func:`weights_digest` checks it at the end).
Rank 0 alone logs, validates and writes checkpoints; a checkpoint keeps every
rank's random states, so a run resumes with the same number of processes.
"""
from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from typing import Mapping

import torch

from ..seeds import TRAINING_STREAM


@dataclass(frozen=True)
class Ranks:
    """Where this process stands: ``rank`` of ``world`` processes, ``local_rank`` on its node."""

    rank: int = 0
    world: int = 1
    local_rank: int = 0

    @property
    def distributed(self) -> bool:
        return self.world > 1

    @property
    def main(self) -> bool:
        """True on the rank that logs, validates and writes."""
        return self.rank == 0


def from_environment(environ: Mapping[str, str] = os.environ) -> Ranks:
    """The :class:`Ranks` that ``torchrun`` describes in ``environ`` (one process without it)."""
    try:
        world = int(environ.get("WORLD_SIZE", "1"))
        rank, local_rank = int(environ.get("RANK", "0")), int(environ.get("LOCAL_RANK", "0"))
    except ValueError:
        raise ValueError("RANK, WORLD_SIZE and LOCAL_RANK must be integers (torchrun sets them)") from None
    if world < 1 or not 0 <= rank < world or local_rank < 0:
        raise ValueError(f"inconsistent torchrun environment: RANK={rank} WORLD_SIZE={world}")
    return Ranks(rank, world, local_rank)


def start(ranks: Ranks, device: str) -> str:
    """Join the process group (when distributed); returns this rank's device (``cuda:LOCAL_RANK`` on CUDA)."""
    if not ranks.distributed:
        return device
    import torch.distributed as dist

    cuda = device.startswith("cuda")
    if cuda:
        torch.cuda.set_device(ranks.local_rank)
        device = f"cuda:{ranks.local_rank}"
    if not dist.is_initialized():
        dist.init_process_group("nccl" if cuda else "gloo")
    return device


def stop(ranks: Ranks) -> None:
    """Leave the process group (when distributed)."""
    if ranks.distributed:
        import torch.distributed as dist
        if dist.is_initialized():
            dist.destroy_process_group()


def shard(items: list, ranks: Ranks) -> list:
    """This rank's share of ``items``: every ``world``-th one from ``rank`` (disjoint, together all)."""
    share = items[ranks.rank::ranks.world]
    if not share:
        raise ValueError(f"{len(items)} training scenes cannot be shared by {ranks.world} processes")
    return share


def seed_sequence(seed: int, ranks: Ranks) -> list[int]:
    """Seed of the batch sampler: the one-process run's, with the rank appended when distributed."""
    return [seed, TRAINING_STREAM] + ([ranks.rank] if ranks.distributed else [])


def wrap(module: torch.nn.Module, ranks: Ranks) -> torch.nn.Module:
    """``module`` in DistributedDataParallel when distributed (weights broadcast from rank 0), else itself."""
    if not ranks.distributed:
        return module
    from torch.nn.parallel import DistributedDataParallel

    on_cuda = next(module.parameters()).is_cuda
    return DistributedDataParallel(module, device_ids=[ranks.local_rank] if on_cuda else None)


def average_gradients(module: torch.nn.Module, ranks: Ranks) -> None:
    """Replace every gradient of ``module`` by its mean over the ranks (in place; a no-op in one process)."""
    if not ranks.distributed:
        return
    import torch.distributed as dist

    for parameter in module.parameters():
        if parameter.grad is not None:
            dist.all_reduce(parameter.grad)
            parameter.grad.div_(ranks.world)


def gather(value, ranks: Ranks) -> list:
    """``value`` of every rank, in rank order (``[value]`` in one process)."""
    if not ranks.distributed:
        return [value]
    import torch.distributed as dist

    values = [None] * ranks.world
    dist.all_gather_object(values, value)
    return values


def weights_digest(*state_dicts: Mapping[str, torch.Tensor]) -> str:
    """sha256 over the names, shapes and bytes of every tensor of ``state_dicts`` (equal iff bit for bit)."""
    digest = hashlib.sha256()
    for state in state_dicts:
        for name, tensor in state.items():
            array = tensor.detach().cpu().contiguous()
            digest.update(f"{name}:{tuple(array.shape)}:{array.dtype}".encode())
            digest.update(array.reshape(-1).view(torch.uint8).numpy().tobytes())
    return digest.hexdigest()
