"""What the budget tests share: a small frame size, a fixed cost model and one frame rendered at a budget."""

SIZE = (40, 32)


def fixed_costs(**changes):
    """A cost model of this repository's test machine's order (seconds a pixel), so that no test measures the machine
    it runs on, and none depends on it; ``changes`` replace fields."""
    from gmcpt.sampling.costs import CostModel

    return CostModel(**{"path": 1.7e-6, "guide_ray": 1.4e-7, "sparse_extra": 4.7e-6, "denoise": 1.5e-6,
                        "denoise_large": 3.5e-6, **changes})


def render_budget(scene, budget, seed=0, costs=None):
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame

    integrator = scene.integrator()
    return render_sparse_frame(scene, getattr(integrator, "integrator", integrator),
                               settings=RenderSettings(budget=budget, seed=seed, costs=costs or fixed_costs()))[0]


def record_launches(monkeypatch) -> list:
    """The samples a pixel of each of a dense frame's launches over (nearly) every pixel: Mitsuba's renders, with or
    without its guides, and pixel-lists of all but a probe's pixels (at least 90% of the frame), as a list that fills
    as frames render."""
    from gmcpt.sampling import dense, trace

    launches = []
    for name in ("render_native", "render_native_guided"):
        launch = getattr(dense, name)
        monkeypatch.setattr(dense, name, lambda *args, launch=launch: launches.append(args[3]) or launch(*args))
    pixel_list = trace.FrameTrace.trace

    def traced(self, pixels, spp, seed):
        if pixels.size >= 0.9 * self.sums.size:
            launches.append(spp)
        return pixel_list(self, pixels, spp, seed)

    monkeypatch.setattr(trace.FrameTrace, "trace", traced)
    return launches
