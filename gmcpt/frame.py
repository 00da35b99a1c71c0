"""The sparse frame: what one masked render hands to the completion stages."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .errors import GmcptError

#: Primary rays per pixel of the feature pass. The traced radiance is an antialiased mean of 16 or so
#: samples; a 1-sample albedo is aliased at texture and silhouette edges, and demodulating one by the
#: other leaves that aliasing in every filled pixel; OIDN, the last stage, reads the same buffers as guides.
#: Measured with the budget default at 4.8 samples a pixel (256x256, 3 seeds, docs/experiments.md): 4 -> 16
#: gains 0.0-0.9 dB a scene (sponza +0.5, still life +0.9) for 0.05 s at 256x256 and 1 s at 1920x1080.
DEFAULT_FEATURE_SPP = 16

#: The per-pixel buffers of a :class:`SparseFrame` and their channels (None: an (H, W) plane).
PIXEL_BUFFERS = {"radiance": 3, "mask": None, "variance": None, "albedo": 3, "normal": 3, "depth": None,
                 "visibility": None, "coverage": None}


#: The sidecar entries of a budget's or a time budget's choice, in the sidecar's order (:meth:`FrameInfo.to_json`).
CHOICE_ENTRIES = ("budget_choice", "probe", "relative_variance", "edge_share", "guide_spp", "dense_placement",
                  "error_concentration", "error_reliability", "denoiser_proxy", "time_spent", "costs")


@dataclass(frozen=True)
class FrameInfo:
    """What a frame records of how it was traced (:func:`gmcpt.sampling.strategies.render_sparse_frame`); None: not
    recorded (the strategy that records it did not run). :meth:`to_json` gives the frame's entries of the sidecar.

    Attributes
    ----------
    pattern : the mask pattern of the settings; seed : their seed.
    feature_spp : the rays a pixel of the feature buffers (a dense frame's guides: ``guide_spp``).
    traced_pixels, path_samples, nonfinite_samples : pixels traced, samples traced, samples that were NaN/Inf.
    first_pass_pixels : the pixels of the first radiance pass (a dense frame: its probe's).
    costs : the cost model a budget or a time budget weighed time with (:meth:`gmcpt.sampling.costs.CostModel.record`).
    budget : a budget's samples a pixel; a time budget's spent ones. budget_choice : ``sparse`` or ``dense``.
    relative_variance, edge_share : what a budget's choice read (None: not read); probe : ``traced`` or ``none``.
    sparse_time_share : the sparse way's extra time, a share of the dense frame's. guide_spp : a budget's guide rays.
    guides : where a dense frame's guides came from, ``pass`` or ``render``.
    error_concentration, error_reliability, dense_placement : a dense frame's readings of its error (how concentrated;
        how far two launches agree on where, read only where the concentration pays, else None) and its placement
        (``adaptive`` or ``even``).
    denoiser_proxy : the reading of what OIDN's large model buys (:mod:`gmcpt.sampling.large_model`).
    time_budget, time_short, time_spent : a time budget's seconds, whether they bought less than one sample a pixel
        and the completion, the seconds the frame took in all.
    dropped_nonfinite_pixels : pixels left out of the mask for non-finite samples
        (:func:`gmcpt.completion.check.sanitize`).
    sequence : a sequence frame's record (:class:`gmcpt.temporal.sequence.SequenceRecord`).
    """

    pattern: str | None = None
    seed: int | None = None
    feature_spp: int | None = None
    traced_pixels: int | None = None
    path_samples: int | None = None
    nonfinite_samples: int | None = None
    first_pass_pixels: int | None = None
    costs: dict | None = None
    budget: float | None = None
    budget_choice: str | None = None
    relative_variance: float | None = None
    probe: str | None = None
    edge_share: float | None = None
    sparse_time_share: float | None = None
    guide_spp: int | None = None
    guides: str | None = None
    error_concentration: float | None = None
    error_reliability: float | None = None
    dense_placement: str | None = None
    denoiser_proxy: float | None = None
    time_budget: float | None = None
    time_short: bool | None = None
    time_spent: float | None = None
    dropped_nonfinite_pixels: int | None = None
    # a SequenceRecord: named, not imported (a layer above), and not annotated so: mi.render's Dr.Jit resolves the
    # annotations of the frame it traverses in this module
    sequence: object | None = None

    def with_values(self, **values) -> FrameInfo:
        """A copy with ``values`` recorded (an unknown name raises TypeError)."""
        return replace(self, **values)

    def to_json(self) -> dict:
        """The frame's entries of the sidecar JSON, in its order: pixels and samples traced, what a budget's choice
        read (a budget's ``relative_variance`` and ``edge_share`` even where not read: null), the spent budget of a
        time budget, the first pass of ``two_pass``, the non-finite samples."""
        read = self.probe is not None  # a budget's choice ran: its readings are recorded, null or not
        choice = {key: getattr(self, key) for key in CHOICE_ENTRIES
                  if getattr(self, key) is not None or (read and key in ("relative_variance", "edge_share"))}
        return {"traced_pixels": self.traced_pixels, "path_samples": self.path_samples, **choice,
                **({"spent_budget": self.budget} if self.time_budget is not None else {}),
                **({"first_pass_pixels": self.first_pass_pixels} if self.pattern == "two_pass" else {}),
                "nonfinite_samples": self.nonfinite_samples}


@dataclass(frozen=True)
class SparseFrame:
    """A sparsely path-traced image and its dense feature buffers.

    All arrays are float32 (``mask`` is bool), row-major ``(H, W, ...)``.

    Attributes
    ----------
    radiance : (H, W, 3) linear RGB, the box estimate of each traced pixel, 0 elsewhere.
    mask : (H, W) bool, True where the pixel was path traced.
    variance : (H, W) variance of the traced pixel mean (average over RGB), 0 elsewhere.
    albedo : (H, W, 3) diffuse reflectance at the first hit, in [0, 1] (0 for misses and for BSDFs without
        a diffuse lobe: glass, metal).
    normal : (H, W, 3) world-space shading normal at the first hit (0 for misses).
    depth : (H, W) hit distance divided by the largest in the image; misses are 1.
    visibility : (H, W) fraction of shadow rays from the first hit that reach a light.
    spp : samples per traced pixel.
    info : how it was traced (:class:`FrameInfo`).
    coverage : (H, W) fraction of the feature rays that hit a surface with a diffuse albedo (see
        :mod:`gmcpt.image.domain`), or None where it was not recorded.
    """

    radiance: np.ndarray
    mask: np.ndarray
    variance: np.ndarray
    albedo: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    visibility: np.ndarray
    spp: int = 1
    info: FrameInfo = field(default_factory=FrameInfo)
    coverage: np.ndarray | None = None

    def __post_init__(self):
        h, w = self.mask.shape
        for name, channels in PIXEL_BUFFERS.items():
            shape = (h, w) if channels is None else (h, w, channels)
            array = getattr(self, name)
            if array is not None and array.shape != shape:
                raise GmcptError(f"SparseFrame.{name} has shape {array.shape}, expected {shape}")
        if self.mask.dtype != bool:
            raise GmcptError("SparseFrame.mask must be a boolean array")

    @property
    def shape(self) -> tuple[int, int]:
        return self.mask.shape

    @property
    def rendered_fraction(self) -> float:
        return float(self.mask.mean())

    def features(self) -> np.ndarray:
        """(H, W, 8) stack of albedo, normal, depth, visibility."""
        return np.concatenate([self.albedo, self.normal, self.depth[..., None],
                               self.visibility[..., None]], axis=-1)
