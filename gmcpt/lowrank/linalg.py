"""Batched symmetric eigendecomposition that survives float32 LAPACK failures."""
from __future__ import annotations

import torch


def stable_eigh(gram: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Batched ``torch.linalg.eigh``, redone in float64 for the matrices float32 LAPACK gets wrong.

    On a near-rank-1 Gram matrix with many (near-)repeated zero eigenvalues,
    float32 ``eigh`` on the CPU can return NaN eigenvectors without raising
    (measured: torch 2.13, a group of 15 identical patches and one other),
    and a NaN then spreads through the image; or it raises. Those matrices
    are decomposed again in float64.
    """
    try:
        lam, vec = torch.linalg.eigh(gram)
    except torch.linalg.LinAlgError:
        lam, vec = torch.linalg.eigh(gram.double())
        return lam.to(gram.dtype), vec.to(gram.dtype)
    bad = ~(torch.isfinite(lam).all(-1) & torch.isfinite(vec).flatten(1).all(-1))
    if bad.any():
        lam64, vec64 = torch.linalg.eigh(gram[bad].double())
        lam[bad], vec[bad] = lam64.to(lam.dtype), vec64.to(vec.dtype)
    return lam, vec
