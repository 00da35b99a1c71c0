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

#: Integrators a scene's state keeps for each frozen kernel's recordings and for the guided twins (a frame uses two
#: to four: the path tracer, its guided twins); the oldest goes first. Both are keyed by the integrator's id, so the
#: integrator is held beside them (else a new integrator at a freed one's address replayed the other's recording:
#: another max_depth traced as the first); the bound keeps a loop that makes an integrator a frame from holding them
#: all.
INTEGRATORS_KEPT = 8


def making_room(keys: list) -> list:
    """The oldest of ``keys`` (a state's entries for integrators, oldest first) to let go so that one more fits within
    :data:`INTEGRATORS_KEPT`."""
    return keys[:max(0, len(keys) - INTEGRATORS_KEPT + 1)]

#: id -> (the scene, its state)
_HELD: dict[int, tuple[object, dict]] = {}


def scene_state(scene) -> dict:
    """The state dict of ``scene`` (empty the first time), after letting go of the scenes nobody else holds."""
    for key in [key for key in _HELD if sys.getrefcount(_HELD[key][0]) <= 2]:  # the tuple and the argument
        del _HELD[key]
    return _HELD.setdefault(id(scene), (scene, {}))[1]
