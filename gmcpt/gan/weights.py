"""Save and load generator weights with their metadata.

A weights file ``NAME.pt`` holds ``{"format", "generator_config", "state_dict"}``
(tensors, strings and numbers only: it loads with ``torch.load(weights_only=True)``).
Beside it, ``NAME.json`` records the training config, the dataset (path,
version, manifest), the training summary, the command that made it and the
file's sha256, which :func:`load_generator` checks. Floating-point tensors are stored in half
precision (:data:`STORED_DTYPE`) and cast back to float32 on loading. The shipped weights live in
``gmcpt/gan/weights/``; :data:`DEFAULT_WEIGHTS` is the one the ``gan`` methods use.
"""
from __future__ import annotations

import json
import warnings
from pathlib import Path

import torch

from ..errors import GmcptError
from ..io.files import atomic_output
from .model import Generator, GeneratorConfig
from .names import DEFAULT_WEIGHTS, checked_weights, retrain_hint, sha256, weights_path  # noqa: F401 (API too)

FORMAT = 1

#: Precision of the stored floating-point tensors: half the file of float32, and the same results to
#: 0.01 dB (docs/experiments.md).
STORED_DTYPE = torch.float16

_cache: dict[tuple[str, float], tuple[Generator, dict]] = {}


def save_weights(path: str | Path, generator: Generator, metadata: dict) -> dict:
    """Write ``path`` (.pt) and ``path.json``; returns the metadata written (with sha256)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    state = {k: _stored(v) for k, v in generator.state_dict().items()}
    payload = {"format": FORMAT, "generator_config": json.dumps(generator.config.to_dict()), "state_dict": state}
    with atomic_output(path) as temporary:
        torch.save(payload, temporary)
    record = {**metadata, "file": path.name, "format": FORMAT, "generator_config": generator.config.to_dict(),
              "stored_dtype": str(STORED_DTYPE).removeprefix("torch."), "sha256": sha256(path),
              "bytes": path.stat().st_size}
    path.with_suffix(".json").write_text(json.dumps(record, indent=1) + "\n")
    return record


def _stored(tensor: torch.Tensor) -> torch.Tensor:
    """A copy of ``tensor`` as written to a weights file: floats in :data:`STORED_DTYPE` where they fit."""
    tensor = tensor.detach().cpu()
    if tensor.is_floating_point():
        rounded = tensor.to(STORED_DTYPE)
        if torch.isfinite(rounded).all() or not torch.isfinite(tensor).all():
            return rounded
    return tensor.clone()


def load_generator(name_or_path: str | Path | None = None, check_hash: bool = True) -> tuple[Generator, dict]:
    """The generator (eval mode) and its metadata; cached per file and modification time.

    Raises
    ------
    GmcptError
        One line, saying how to retrain, when the file is missing, corrupt or
        does not match its recorded hash.
    """
    path, metadata, _ = checked_weights(name_or_path, check_hash)
    key = (str(path.resolve()), path.stat().st_mtime)
    if key in _cache:
        return _cache[key]
    hint = retrain_hint(path)
    try:
        with warnings.catch_warnings():  # torch's warnings about a file it then refuses: the error says it all
            warnings.simplefilter("ignore")
            payload = torch.load(path, map_location="cpu", weights_only=True)
        if not isinstance(payload, dict) or payload.get("format") != FORMAT:
            raise ValueError(f"format {payload.get('format') if isinstance(payload, dict) else None}, "
                             f"expected {FORMAT}")
        generator = Generator(GeneratorConfig.from_dict(json.loads(payload["generator_config"])))
        generator.load_state_dict(payload["state_dict"])
    except Exception as error:  # unpickling, shape or key errors: all mean a bad file
        message = " ".join(str(error).split())[:200]
        raise GmcptError(f"GAN weights {path} are corrupt or incompatible ({type(error).__name__}: {message}); "
                         f"{hint}") from None
    generator.eval()
    for parameter in generator.parameters():
        parameter.requires_grad_(False)
    _cache[key] = (generator, metadata)
    return generator, metadata
