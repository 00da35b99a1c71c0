"""Patch-group low-rank completion (block matching + PAWNNM).

Depends only on numpy and torch.  See :func:`complete_low_rank`
(:mod:`~gmcpt.lowrank.pawnnm`) and its settings, :class:`LowRankParams` and the
measured presets (:mod:`~gmcpt.lowrank.params`).

The names below are imported on first use (PEP 562), so that importing the
settings alone (as ``import gmcpt`` does) does not import torch.
"""
from __future__ import annotations

import importlib

_HOMES = {"LowRankParams": "params", "DEFAULT": "params", "PAPER_PRESET": "params", "NNM_PRESET": "params",
          "complete_low_rank": "pawnnm", "complete_matrix": "pawnnm", "low_rank_estimate": "pawnnm",
          "block_match": "matching", "matching_signal": "matching", "reference_positions": "patches"}

__all__ = list(_HOMES)


def __getattr__(name: str):
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f".{_HOMES[name]}", __name__), name)


def __dir__() -> list[str]:
    return sorted(list(globals()) + __all__)
