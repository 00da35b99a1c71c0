"""What the budget tests share: a small frame size and one frame rendered at a budget."""

SIZE = (40, 32)


def render_budget(scene, budget, seed=0):
    from gmcpt.sampling import RenderSettings, render_sparse_frame

    integrator = scene.integrator()
    return render_sparse_frame(scene, getattr(integrator, "integrator", integrator),
                               settings=RenderSettings(budget=budget, seed=seed))[0]


def record_launches(monkeypatch) -> list:
    """The samples a pixel of each of a dense frame's renders of every pixel, with or without its guides, as a list
    that fills as frames render."""
    from gmcpt import dense

    launches = []
    for name in ("render_native", "render_native_guided"):
        launch = getattr(dense, name)
        monkeypatch.setattr(dense, name, lambda *args, launch=launch: launches.append(args[3]) or launch(*args))
    return launches
