"""The GAN generator on CPU: PyTorch eager against OpenVINO, the network alone and ``generator_fill`` whole.

Renders the still life at rate 0.3, 16 spp, at each ``--sizes``; then, in one warm process, times in turns
(``--repeats`` calls each, after a warm-up) the generator stage (:func:`gmcpt.completion.learned.generator_fill`:
inputs, fill, network, output) with the network in PyTorch (``$GMCPT_GENERATOR_RUNTIME=torch``) and on
OpenVINO, and the network alone on the same inputs and fill (:func:`gmcpt.gan.infer.generate` against the
compiled network). Prints the medians, the speed-up and the largest difference of the outputs (the network's
in the working domain / 255, ``generator_fill``'s in the working domain, 0..255-like), both in the
precision :func:`gmcpt.runtime.device.generator_precision` picks here.

    python benchmarks/generator_runtime.py [--sizes 256x256 1920x1080] [--repeats 7] [--scene SCENE.xml]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def render(scene_path: str, width: int, height: int):
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame
    from gmcpt.render.scene import load_scene

    scene = load_scene(scene_path, (width, height))
    return render_sparse_frame(scene, scene.integrator(), settings=RenderSettings(rate=0.3, spp=16))[0]


def on_runtime(runtime: str, call):
    """``call`` with ``$GMCPT_GENERATOR_RUNTIME`` set to ``runtime``."""
    def run():
        os.environ["GMCPT_GENERATOR_RUNTIME"] = runtime
        return call()
    return run


def compare(calls: dict, repeats: int) -> tuple[dict, dict]:
    """(median seconds, last output) of each call, timed in turns after one warm-up call each."""
    times = {name: [] for name in calls}
    outputs = {name: call() for name, call in calls.items()}
    for _ in range(repeats):
        for name, call in calls.items():
            start = time.perf_counter()
            outputs[name] = call()
            times[name].append(time.perf_counter() - start)
    return {name: statistics.median(seconds) for name, seconds in times.items()}, outputs


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["256x256", "1920x1080"], help="WIDTHxHEIGHT")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--scene", default=str(ROOT / "scenes" / "still-life" / "scene.xml"))
    args = parser.parse_args()

    from gmcpt.completion.learned import generator_fill
    from gmcpt.runtime.device import generator_precision, generator_threads
    from gmcpt.image.domain import WorkingDomain
    from gmcpt.gan.infer import exposed, generate, network_inputs, prepare, target_exposure
    from gmcpt.gan.runtime import cpu_network
    from gmcpt.gan.weights import load_generator

    generator = prepare(load_generator()[0], "cpu")
    threads, precision = generator_threads(), generator_precision("cpu")
    network = cpu_network(None, precision, threads)
    if network is None:
        return 1
    print(f"{threads} threads, {precision}, load average {os.getloadavg()[0]:.2f}")
    print(f"{'size':>10} {'stage':>15} {'pytorch_s':>10} {'openvino_s':>10} {'speed-up':>8} {'max_diff':>9}")
    for size in args.sizes:
        width, height = map(int, size.split("x"))
        frame = render(args.scene, width, height)
        radiance, features, fill, _ = network_inputs(generator, exposed(frame, target_exposure(frame)), WorkingDomain())
        pixels = [tensor.permute(0, 2, 3, 1).numpy() for tensor in (radiance, features, fill)]
        stages = {
            "network": {"torch": lambda: generate(generator, radiance, features, threads, precision, fill)
                        .permute(0, 2, 3, 1).numpy(),
                        "openvino": lambda: pixels[2] + network(*pixels)},
            "generator_fill": {runtime: on_runtime(runtime, lambda: generator_fill(frame)[0])
                               for runtime in ("torch", "openvino")}}
        for stage, calls in stages.items():
            seconds, outputs = compare(calls, args.repeats)
            difference = float(np.abs(outputs["torch"] - outputs["openvino"]).max())
            print(f"{size:>10} {stage:>15} {seconds['torch']:10.4f} {seconds['openvino']:10.4f} "
                  f"{seconds['torch'] / seconds['openvino']:7.2f}x {difference:9.2e}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
