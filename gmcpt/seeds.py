"""Every random stream of the project, named in one place.

A frame's sampler seed (``--seed``) is the root; each pass that must draw samples of its own adds its stream's offset
(:func:`stream`), so that two passes of one frame never trace the same samples, and the same arguments give the same
samples on any machine. Offsets are far apart (they only need to differ) and never change: a changed offset changes
every image that depends on it, goldens included.
"""
from __future__ import annotations

from .limits import SEED_LIMIT

# --- a single frame (gmcpt.sampling.strategies, gmcpt.sampling.dense, gmcpt.render.kernels) ---
#: the feature pass's rays (albedo, normal, depth, visibility)
FEATURE_SEED_OFFSET = 0x5EED_F00D
#: the second radiance pass of ``two_pass`` draws other samples
SECOND_PASS_SEED_OFFSET = 0x2BA55
#: the probe's placement
PROBE_SEED_OFFSET = 0x9B0BE
#: the sparse way's first pass beside the probe (same seed: same lanes' samples)
FIRST_PASS_SEED_OFFSET = 0xF1257
#: the sparse way's feature rays beside the guides'
GUIDE_TOP_UP_SEED_OFFSET = 0x6D1E
#: the samples after the bulk (and a sparse frame's probe pixels after the choice)
TOP_UP_SEED_OFFSET = 0x70B0F
#: the dense way's blue-noise spread of the samples left over
EVEN_SEED_OFFSET = 0xE7E4
#: the second quarter and the half of a frame that reads the denoiser
SPLIT_SEED_OFFSETS = (0x5B1, 0x5B2)
#: the guide rays a frame adds to its render's first hits
GUIDE_RAYS_SEED_OFFSET = 0x6D1F
#: the guide rays a dense frame adds up to 16
CLEAN_GUIDE_SEED_OFFSET = 0xC1EA
#: adaptive path tracing's second pass
EXTRA_SEED_OFFSET = 0xADA97
#: the second launch of a dense frame's first pass that is read twice (gmcpt.sampling.budget.reads_reliability)
RELIABILITY_SEED_OFFSET = 0x2E11A

# --- sample placement (gmcpt.sampling.masks) ---
#: the mask patterns' generator, beside the frame's seed ('mask')
MASK_STREAM = 0x6D61736B
#: the blue-noise threshold map, one for every frame
THRESHOLD_MAP_SEED = 0x7B1E

# --- sequences (gmcpt.temporal.sequence) ---
#: frame i of a sequence draws from ``seed + i * FRAME_SEED_STEP``
FRAME_SEED_STEP = 0x9E37
#: a sequence frame's samples above the level every pixel gets
SEQUENCE_TOP_UP_SEED_OFFSET = 1
#: a timed sequence frame's pass k (k >= 1) of one sample a pixel after its first draws from this offset + k
SEQUENCE_PASS_SEED_OFFSET = 0x100
#: a sequence frame's light probe (gmcpt.temporal.gradient): its pixels and their samples, replayed by the next frame
SEQUENCE_PROBE_SEED_OFFSET = 0x300

# --- training (gmcpt.gan) ---
#: the training data's order, beside the run's seed
TRAINING_STREAM = 0x7EA1
#: each distributed rank's torch seed: ``seed + TRAINING_RANK_STEP * rank``
TRAINING_RANK_STEP = 7919

# --- evaluation, references and datasets ---
#: the baselines of the evaluation draw other samples than the default's
BASELINE_SEED_OFFSET = 17
#: the seeds of a contender's timed runs: ``seed + RUN_SEED_STEP * run``
RUN_SEED_STEP = 1000
#: the second of two independent references of a scene
SECOND_REFERENCE_SEED = 2_000_003
#: the two independent references of a sequence's frame
SEQUENCE_REFERENCE_SEEDS = (7_000_000, 8_000_000)
#: a reference frame's passes in ``gmcpt compare --frames``: ``seed + COMPARE_FRAME_STEP * frame``
COMPARE_FRAME_STEP = 97
#: ``gmcpt reference``'s and the goldens' first pass (the passes use seed, seed + 1, ...)
REFERENCE_FIRST_SEED = 1_000_003
#: the dataset splits' first seeds, each split this many seeds wide
SPLIT_SEED_BASE = {"train": 0, "val": 1_000_000, "test": 2_000_000}
SEEDS_PER_SPLIT = 1_000_000
#: a dataset example's reference, apart from every split's
DATASET_REFERENCE_SEED = 0x4000_0000


def stream(seed: int, offset: int) -> int:
    """The seed of the pass ``offset`` names, beside a frame's ``seed``, within the samplers' 32 bits."""
    return (int(seed) + offset) % SEED_LIMIT
