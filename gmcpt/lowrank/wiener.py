"""Collaborative Wiener filtering of patch groups against a pilot estimate.

The second step of BM3D (Dabov et al. 2007), in the low-rank basis of this
package: once an estimate (the *pilot*) exists, each group of similar patches
is filtered again, this time from the noisy rendered samples, with shrinkage
factors taken from the pilot instead of from the noisy data.

For a group, let ``P`` be the pilot's ``K x d`` group matrix and ``Y`` the
observed one (the rendered samples where a pixel was traced, the pilot
elsewhere), both with their mean patch removed. The eigenvectors ``V`` of
``P P^T`` (how the K patches vary together) give the basis; the pilot's
energy along component ``i`` is its eigenvalue ``lambda_i``, and white noise
of per-entry variance ``sigma^2`` puts ``d * sigma^2`` of energy on every
component. The estimate is

    Y_hat = V diag(lambda / (lambda + s * d * sigma^2)) V^T Y + mean(Y)

with ``sigma^2`` the group's mean per-entry variance (0 at untraced pixels)
and ``s`` the noise scale (:attr:`~gmcpt.lowrank.LowRankParams.wiener`). It is a
linear filter of the samples, so the pilot's own errors (residual noise,
blotches) do not pass into the result, only its sense of which patches agree.
"""
from __future__ import annotations

import torch


def group_wiener(pilot: torch.Tensor, observed: torch.Tensor, noise: torch.Tensor,
                 noise_scale: float) -> torch.Tensor:
    """Wiener-filter ``(G, K, d)`` observed groups with the shrinkage of their pilot groups.

    Parameters
    ----------
    pilot, observed : torch.Tensor
        ``(G, K, d)`` group matrices (row k = patch k) of the pilot estimate and of the observations.
    noise : torch.Tensor
        ``(G, K, d)`` variance of each observed entry (0 where the entry is the pilot's).
    noise_scale : float
        Multiplies the noise energy in the Wiener factors (> 0; larger smooths more).

    Returns
    -------
    torch.Tensor
        ``(G, K, d)`` filtered groups.
    """
    from .pawnnm import _eigh

    centred_pilot = pilot - pilot.mean(1, keepdim=True)
    mean = observed.mean(1, keepdim=True)
    lam, vectors = _eigh(centred_pilot @ centred_pilot.mT)             # (G, K), (G, K, K)
    lam = lam.clamp_min(0.0)
    noise_energy = noise_scale * pilot.shape[-1] * noise.mean((1, 2))[:, None]
    factor = lam / (lam + noise_energy).clamp_min(torch.finfo(lam.dtype).tiny)
    return ((vectors * factor[:, None, :]) @ vectors.mT) @ (observed - mean) + mean
