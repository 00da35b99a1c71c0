import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"
CORNELL = SCENES / "cornell-box" / "scene.xml"
STILL_LIFE = SCENES / "still-life" / "scene.xml"


def pytest_collection_modifyitems(config, items):
    """Tests marked ``cuda`` skip, with one reason, where torch sees no CUDA device."""
    marked = [item for item in items if item.get_closest_marker("cuda")]
    if marked:
        import torch
        if not torch.cuda.is_available():
            for item in marked:
                item.add_marker(pytest.mark.skip(reason="torch sees no CUDA device"))


@pytest.fixture(scope="session")
def mi():
    import gmcpt  # noqa: F401  (variant + plugin registration)
    import mitsuba
    mitsuba.set_log_level(mitsuba.LogLevel.Error)
    return mitsuba


@pytest.fixture
def breakfast_room():
    from gmcpt.evaluation.scenes import BREAKFAST

    if not BREAKFAST.available():
        pytest.skip(f"breakfast-room scene not found at {BREAKFAST.path} (shared scenes absent)")
    return BREAKFAST.path


def run_cli(*args, cwd=None):
    """Run render_and_complete.py; returns the CompletedProcess (text)."""
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    return subprocess.run([sys.executable, str(ROOT / "render_and_complete.py"), *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, env=env, timeout=600)


def synthetic_frame(height=48, width=64, rate=0.3, seed=0):
    """A SparseFrame of a smooth analytic image over a two-albedo floor."""
    from gmcpt.frame import SparseFrame
    from gmcpt.sampling.masks import make_mask

    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    shading = 0.2 + 0.6 * np.exp(-((x - width / 2) ** 2 + (y - height / 3) ** 2) / (2 * (width / 3) ** 2))
    albedo = np.where((x // 8 + y // 8)[..., None] % 2 == 0, [0.8, 0.3, 0.2], [0.2, 0.6, 0.8]).astype(np.float32)
    clean = (shading[..., None] * albedo).astype(np.float32)
    mask = make_mask(height, width, rate, "random", seed)
    normal = np.zeros((height, width, 3), np.float32); normal[..., 1] = 1
    frame = SparseFrame(radiance=np.where(mask[..., None], clean, 0).astype(np.float32), mask=mask,
                        variance=np.zeros((height, width), np.float32), albedo=albedo, normal=normal,
                        depth=np.full((height, width), 0.5, np.float32),
                        visibility=np.ones((height, width), np.float32), spp=16)
    return frame, clean


def write_blob(path: Path, side: int = 200) -> None:
    """An OBJ of a bumpy sphere without normals, ``side`` x ``side`` vertices: enough faces that Mitsuba sums its
    normals on all its threads (float atomics: other bits from load to load)."""
    import numpy as np

    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, side), np.linspace(0.1, np.pi - 0.1, side))
    radius = 1 + 0.1 * np.sin(5 * u) * np.sin(3 * v)
    points = np.stack([radius * np.cos(u) * np.sin(v), radius * np.sin(u) * np.sin(v), radius * np.cos(v)], -1)
    corner = (np.arange(side - 1)[:, None] * side + np.arange(side - 1)[None, :]).ravel() + 1
    faces = np.concatenate([np.stack([corner, corner + 1, corner + side + 1], 1),
                            np.stack([corner, corner + side + 1, corner + side], 1)])
    path.write_text("".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in points.reshape(-1, 3))
                    + "".join(f"f {a} {b} {c}\n" for a, b, c in faces))
