"""What the budget tests share: a small frame size and one frame rendered at a budget."""

SIZE = (40, 32)


def render_budget(scene, budget, seed=0):
    from gmcpt.sampling import RenderSettings, render_sparse_frame

    integrator = scene.integrator()
    return render_sparse_frame(scene, getattr(integrator, "integrator", integrator),
                               settings=RenderSettings(budget=budget, seed=seed))[0]
