"""The limits a render is checked against before any work starts, in one place for the command line,
the ``masked_path`` plugin and the Python API (each names the option its own way; the rest of the
message is the same).

- seeds: the samplers take 32-bit unsigned seeds, so a seed is an integer in [0, 2^32).
- ``spp``: at least 1, at most :data:`MAX_SPP` samples per traced pixel (16 times the 4096 of a
  converged reference); more is hours of rendering per megapixel, so it is refused at once.
- ``feature_spp``: at least 1, at most :data:`MAX_FEATURE_SPP`; the feature pass traces the whole
  frame's rays in one launch indexed by 32-bit integers, so ``W * H * feature_spp`` stays below 2^32.
- resolution: a run holds about :data:`BYTES_PER_PIXEL` per pixel at its peak, which must fit in the
  memory available now (:func:`available_memory`; read for frames above :data:`ALWAYS_FITS_BYTES`); a larger
  image is refused with what it needs.
"""
from __future__ import annotations

import math
import numbers
import os
from pathlib import Path

from .errors import GmcptError

SEED_LIMIT = 1 << 32
MAX_SPP = 1 << 16
MAX_FEATURE_SPP = 1024
MAX_SECONDS = 7 * 24 * 3600  # a week: a time budget beyond that is a typo
LANE_LIMIT = 1 << 32
#: Peak memory per pixel, rounded up: measured peak RSS of the command line at 512x512 and
#: 1024x1024 (1 spp, 4 feature spp) grows by 250 bytes per pixel with ``none``, 570 with ``pawnnm``
#: and 690 with ``gan_pawnnm`` (the feature rays are not stored: 16 and 64 feature spp cost the same).
BYTES_PER_PIXEL = 1024
#: Frames that need less than this are not checked against the memory available: any machine that runs Mitsuba
#: has it, and reading ``/proc`` costs 0.5 ms, half a percent of a warm 256x256 frame.
ALWAYS_FITS_BYTES = 256 << 20


def _integer(value, name: str, limits: str) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise GmcptError(f"{name} must be an integer {limits}, got {value!r}")
    return int(value)


def check_seed(seed, name: str = "seed") -> int:
    """``seed`` as an int in [0, 2^32), else a one-line :class:`GmcptError`."""
    limits = f"in [0, {SEED_LIMIT - 1}]"
    seed = _integer(seed, name, limits)
    if not 0 <= seed < SEED_LIMIT:
        raise GmcptError(f"{name} must be {limits} (the samplers take 32-bit seeds), got {seed}")
    return seed


def _check_count(value, name: str, maximum: int, why: str) -> int:
    value = _integer(value, name, ">= 1")
    if value < 1:
        raise GmcptError(f"{name} must be >= 1, got {value}")
    if value > maximum:
        raise GmcptError(f"{name} must be at most {maximum} ({why}), got {value}")
    return value


def check_positive(value, name: str, maximum: float, unit: str) -> float:
    """``value`` as a finite float in (0, ``maximum``], else a one-line :class:`GmcptError` that names ``unit``."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise GmcptError(f"{name} must be a number of {unit} in (0, {maximum}], got {value!r}") from None
    if not math.isfinite(number) or not 0 < number <= maximum:
        raise GmcptError(f"{name} must be in (0, {maximum}] {unit}, got {value}")
    return number


def check_seconds(seconds, name: str = "time") -> float:
    """A time budget in seconds: in (0, :data:`MAX_SECONDS`]."""
    return check_positive(seconds, name, MAX_SECONDS, "seconds")


def check_spp(spp, name: str = "spp") -> int:
    """Samples per traced pixel: in [1, :data:`MAX_SPP`]."""
    return _check_count(spp, name, MAX_SPP, "16 times a converged 4096-spp reference; more takes hours "
                        "per megapixel")


def check_feature_spp(feature_spp, name: str = "feature_spp") -> int:
    """Samples per pixel of the feature pass: in [1, :data:`MAX_FEATURE_SPP`]."""
    return _check_count(feature_spp, name, MAX_FEATURE_SPP, "the features converge within a few samples; "
                        "the default is 16")


def _size(count: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB"):
        if count < 1024 or unit == "TiB":
            return f"{count:.0f} {unit}" if unit == "bytes" else f"{count:.1f} {unit}"
        count /= 1024


def available_memory() -> int | None:
    """Bytes of memory this process can still use: ``MemAvailable``, within a cgroup's limit; None if unknown."""
    available = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                available = int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        try:
            available = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (OSError, ValueError, AttributeError):
            return None
    try:
        cgroup = Path("/sys/fs/cgroup")
        limit = (cgroup / "memory.max").read_text().strip()
        if limit != "max":
            left = int(limit) - int((cgroup / "memory.current").read_text())
            available = left if available is None else min(available, left)
    except (OSError, ValueError):
        pass
    return available


def check_resolution(width, height, feature_spp, name: str = "resolution") -> tuple[int, int]:
    """Refuse an image that is empty, has more feature rays than one launch can index, or cannot fit in memory."""
    width, height = (_integer(side, name, ">= 1") for side in (width, height))
    if min(width, height) < 1:
        raise GmcptError(f"{name} must be positive, got {width} {height}")
    needed = width * height * BYTES_PER_PIXEL
    available = available_memory() if needed > ALWAYS_FITS_BYTES else None
    if available is not None and needed > available:
        raise GmcptError(f"image {width}x{height} needs about {_size(needed)} of memory "
                         f"(about {_size(BYTES_PER_PIXEL)} per pixel), {_size(available)} is available; "
                         f"lower the resolution")
    feature_spp = check_feature_spp(feature_spp)
    rays = width * height * feature_spp
    if rays >= LANE_LIMIT:
        raise GmcptError(f"image {width}x{height} at {feature_spp} feature spp is {rays} feature rays, more than "
                         f"one launch can index (2^32); lower the resolution or feature_spp")
    return width, height
