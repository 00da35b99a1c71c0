"""Speed and quality of the low-rank completion (PAWNNM) on a synthetic frame.

Times :func:`gmcpt.lowrank.complete_low_rank` at 256x256 and 512x512 for the
paper's literal preset, the NNM ablation and the tuned default (median over
``--repeats`` runs; the slow paper preset runs ``--paper-repeats`` times;
``torch.set_num_threads(--threads)``) and prints the PSNR each reaches against
the known clean image.  The test frame is procedural (smooth shading, hard
edges, stripes and checks, in a 0..255 working-domain-like range); a fraction
``--rate`` of its pixels are "rendered" with heteroscedastic Gaussian noise of
known variance, and the rest is pre-completed by a normalised-convolution fill.

    python benchmarks/completion_speed.py            # full paper preset (45 iterations: minutes)
    python benchmarks/completion_speed.py --quick    # paper preset capped at 5 iterations
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def synthetic_frame(size: int = 256, *, rate: float = 0.3, noise: float = 12.0, seed: int = 0):
    """A procedural test frame with sparse noisy samples.

    Returns a dict with ``reference`` (H, W, 3) clean image in 0..255,
    ``observed`` (noisy samples, 0 where not rendered), ``mask`` (H, W) bool
    with exactly round(rate*H*W) True pixels, ``variance`` (H, W) of the
    sample noise, ``guide`` (H, W, 2) clean structure features (0..255) and
    ``pre_completed`` (normalised-convolution fill of the samples).
    """
    rng = np.random.default_rng(seed)
    h = w = size
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64) / size
    # smooth shading
    base = 110 + 40 * np.cos(2 * np.pi * (0.7 * xx + 0.3 * yy)) + 25 * np.sin(2 * np.pi * 1.3 * yy)
    label = np.zeros((h, w))
    img = np.repeat(base[..., None], 3, -1) * np.array([1.0, 0.9, 0.8])
    # textured regions: stripes of several periods / orientations, a checkerboard
    regions = [((0.05, 0.05, 0.45, 0.4), "stripes", 6.0, 0.3),
               ((0.55, 0.1, 0.95, 0.45), "stripes", 9.0, 1.2),
               ((0.1, 0.55, 0.45, 0.95), "checks", 8.0, 0.0),
               ((0.55, 0.55, 0.9, 0.9), "stripes", 4.5, 2.2)]
    for i, ((y0, x0, y1, x1), kind, period, angle) in enumerate(regions):
        inside = (yy >= y0) & (yy < y1) & (xx >= x0) & (xx < x1)
        px, py = xx * size, yy * size
        if kind == "stripes":
            t = np.cos(angle) * px + np.sin(angle) * py
            pat = (np.sin(2 * np.pi * t / period) > 0).astype(float)
        else:
            pat = ((np.floor(px / period) + np.floor(py / period)) % 2).astype(float)
        color = rng.uniform(40, 220, 3)
        img[inside] = (0.55 * img[inside] + 0.45 * (pat[inside, None] * color
                                                      + (1 - pat[inside, None]) * (255 - color)))
        label[inside] = (i + 1) * 40 + 20 * pat[inside]
    # a few flat discs with hard edges
    for _ in range(6):
        cy, cx, rad = rng.uniform(0.1, 0.9), rng.uniform(0.1, 0.9), rng.uniform(0.04, 0.1)
        disc = (yy - cy) ** 2 + (xx - cx) ** 2 < rad ** 2
        img[disc] = rng.uniform(30, 230, 3)
        label[disc] = rng.uniform(0, 255)
    ref = np.clip(img, 0, 255).astype(np.float32)

    n = h * w
    mask = np.zeros(n, bool)
    mask[rng.permutation(n)[: int(round(rate * n))]] = True
    mask = mask.reshape(h, w)
    std = noise * rng.uniform(0.5, 1.5, (h, w))
    noisy = ref + std[..., None] * rng.standard_normal(ref.shape)
    observed = np.where(mask[..., None], noisy, 0.0).astype(np.float32)
    guide = np.stack([label, 255 * base / base.max()], -1)
    return dict(reference=ref, observed=observed, mask=mask,
                variance=np.where(mask, std ** 2, 0.0).astype(np.float32),
                guide=guide.astype(np.float32),
                pre_completed=normalized_convolution_fill(observed, mask))


def normalized_convolution_fill(observed, mask, sigma: float = 1.5):
    """Gaussian normalised convolution of the samples: a simple everywhere-filled estimate."""
    m = mask.astype(np.float64)
    num = np.stack([ndimage.gaussian_filter(observed[..., c] * m, sigma)
                    for c in range(observed.shape[-1])], -1)
    den = ndimage.gaussian_filter(m, sigma)[..., None]
    out = num / np.maximum(den, 1e-8)
    # far from any sample: widen the kernel
    wide = np.stack([ndimage.gaussian_filter(observed[..., c] * m, 4 * sigma)
                     for c in range(observed.shape[-1])], -1)
    wide = wide / np.maximum(ndimage.gaussian_filter(m, 4 * sigma)[..., None], 1e-8)
    return np.where(den > 1e-3, out, wide).astype(np.float32)


def psnr(x, ref, peak: float = 255.0) -> float:
    mse = float(np.mean((np.asarray(x, np.float64) - ref) ** 2))
    return 10 * np.log10(peak ** 2 / mse)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 512])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--rate", type=float, default=0.3)
    ap.add_argument("--noise", type=float, default=12.0)
    ap.add_argument("--paper-repeats", type=int, default=1)
    ap.add_argument("--quick", action="store_true",
                    help="cap the paper preset at --quick-iterations")
    ap.add_argument("--quick-iterations", type=int, default=5)
    ap.add_argument("--presets", nargs="+", default=["paper", "nnm", "default"],
                    choices=["paper", "nnm", "default"])
    ap.add_argument("--device", default="cpu")
    args = ap.parse_args(argv)

    import torch
    from gmcpt.lowrank import DEFAULT, NNM_PRESET, PAPER_PRESET, complete_low_rank

    torch.set_num_threads(args.threads)
    paper = PAPER_PRESET
    if args.quick:
        paper = replace(paper, iterations=min(paper.iterations, args.quick_iterations))
    presets = [("paper" + (f" (capped at {paper.iterations} it)" if args.quick else ""), paper,
                args.paper_repeats),
               ("nnm", NNM_PRESET, args.repeats),
               ("default", DEFAULT, args.repeats)]
    presets = [pr for pr in presets if pr[0].split()[0] in args.presets]
    print(f"torch {torch.__version__}, {args.threads} threads, device {args.device}, "
          f"rate {args.rate}, noise std {args.noise} (0..255 scale); CPU s is process CPU "
          f"time (wall s > CPU s / threads means the machine was busy)", flush=True)
    for name, prm, _ in presets:
        print(f"  {name}: {prm}", flush=True)
    rows = []
    for size in args.sizes:
        fr = synthetic_frame(size, rate=args.rate, noise=args.noise)
        base_psnr = psnr(fr["pre_completed"], fr["reference"])
        for name, prm, reps in presets:
            prm = replace(prm, device=args.device)
            times, cpus, out, tim = [], [], None, None
            for _ in range(reps):
                t0, c0 = time.perf_counter(), time.process_time()
                out, tim = complete_low_rank(fr["pre_completed"], fr["observed"], fr["mask"],
                                             variance=fr["variance"], params=prm)
                times.append(time.perf_counter() - t0)
                cpus.append(time.process_time() - c0)
            row = (size, name, prm.iterations, float(np.median(times)), float(np.median(cpus)),
                   tim["block_matching_s"],
                   tim["svd_s"], tim["aggregation_s"], base_psnr, psnr(out, fr["reference"]))
            rows.append(row)
            print("  done %dx%d %-28s median %.2f s over %d run(s), %.2f dB"
                  % (size, size, name, row[3], reps, row[-1]), flush=True)
    print()
    print("| size | preset | iters | wall s (median) | CPU s (median) | matching s | svd s "
          "| aggregation s | PSNR pre-completion dB | PSNR out dB |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print("| %dx%d | %s | %d | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |"
              % (r[0], r[0], *r[1:]), flush=True)


if __name__ == "__main__":
    main()
