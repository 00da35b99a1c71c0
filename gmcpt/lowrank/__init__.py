"""Patch-group low-rank completion (block matching + PAWNNM).

Depends only on numpy and torch.  See :func:`complete_low_rank`
(:mod:`~gmcpt.lowrank.pawnnm`) and its settings, :class:`LowRankParams` and the
measured presets (:mod:`~gmcpt.lowrank.params`).
"""
from .matching import block_match, matching_signal
from .patches import reference_positions
from .params import DEFAULT, NNM_PRESET, PAPER_PRESET, LowRankParams
from .pawnnm import complete_low_rank, complete_matrix, low_rank_estimate

__all__ = ["LowRankParams", "DEFAULT", "PAPER_PRESET", "NNM_PRESET", "complete_low_rank",
           "complete_matrix", "low_rank_estimate", "block_match", "matching_signal", "reference_positions"]
