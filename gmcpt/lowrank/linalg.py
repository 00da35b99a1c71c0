"""Batched symmetric eigendecomposition and Cholesky factorisation that survive float32 LAPACK failures."""
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


def stable_cholesky(system: torch.Tensor) -> torch.Tensor:
    """Batched lower Cholesky factors, redone in float64 for the systems float32 LAPACK rejects.

    The systems are symmetric positive definite in exact arithmetic (a Gram matrix plus a positive
    ridge), but float32 rounding can leave one that float32 Cholesky reports as indefinite.
    """
    factor, info = torch.linalg.cholesky_ex(system)
    failed = info > 0
    if failed.any():
        factor[failed] = torch.linalg.cholesky(system[failed].double()).to(system.dtype)
    return factor
