"""State kept per Mitsuba scene for as long as someone else holds the scene: the frozen kernels' recordings
(:mod:`gmcpt.render.kernels`) and the integrators' guided twins (:mod:`gmcpt.render.guided_path`). Nothing here changes
what a frame chooses or draws: a frame's choice reads the frame alone (:mod:`gmcpt.sampling.costs`).

Keyed by the scene's ``id``, so the registry holds the scene itself: no other scene can take its id, and with it
its recordings or twins, while they live (a ``mi.Scene`` takes no weak reference). One registry for all of it,
as two that each held the scene would each see the other's reference and never let go (an evaluation run kept
every scene it had loaded, and each Dr.Jit virtual call traced the shapes and BSDFs of all of them).
"""
from __future__ import annotations

import sys

#: id -> (the scene, its state)
_HELD: dict[int, tuple[object, dict]] = {}


def scene_state(scene) -> dict:
    """The state dict of ``scene`` (empty the first time), after letting go of the scenes nobody else holds."""
    for key in [key for key in _HELD if sys.getrefcount(_HELD[key][0]) <= 2]:  # the tuple and the argument
        del _HELD[key]
    return _HELD.setdefault(id(scene), (scene, {}))[1]
