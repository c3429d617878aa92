"""``mitsuba``: the Mitsuba 3 ground truth as a technique (path + ptracer composite).

``Renderer().render(scene, "mitsuba", spp=256)`` renders
:func:`caustica.reference.render_reference` with the renderer's ``spp`` as
Mitsuba's samples per pixel (per integrator). Results are cached on disk
(``$CAUSTICA_CACHE`` or ``~/.cache/caustica/reference``) unless ``cache`` is
false. This module imports without Mitsuba; rendering without it raises
:class:`caustica.errors.ReferenceUnavailableError`.

Limits: see :mod:`caustica.reference.render` (a point-light caustic seen
through glass or in a mirror is missing; spot falloff is Mitsuba's).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import Technique


@dataclass
class MitsubaParams:
    """``max_depth``: Mitsuba's path length limit; ``cache``: read and write the on-disk cache."""

    max_depth: int = 16
    cache: bool = True

    def __post_init__(self):
        if isinstance(self.max_depth, bool) or not isinstance(self.max_depth, (int, np.integer)):
            raise ValueError(f"max_depth must be an integer, got {self.max_depth!r}")
        if not (self.max_depth == -1 or 1 <= self.max_depth <= 1024):
            raise ValueError(f"max_depth {self.max_depth} must be -1 (unbounded) or between 1 and 1024")
        if not isinstance(self.cache, (bool, np.bool_)):
            raise ValueError(f"cache must be true or false, got {self.cache!r}")


class MitsubaReference(Technique):
    """Path-traced ground truth from Mitsuba 3 (path for specular views, ptracer for caustics)."""

    name = "mitsuba"
    summary = "Ground truth from Mitsuba 3: path tracing composited with light tracing for caustics (CPU, cached)"
    Params = MitsubaParams
    uses_gl = False
    square_spp = False  # Mitsuba's independent sampler takes any count

    def render(self, renderer, scene, camera, params, spp: int) -> np.ndarray:
        from ..reference.render import render_reference

        params = params if params is not None else MitsubaParams()
        return render_reference(scene, spp=spp, camera=camera, max_depth=params.max_depth, cache=params.cache)
