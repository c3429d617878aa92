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

from .base import Params, Technique, param


@dataclass
class MitsubaParams(Params):
    """``max_depth``: Mitsuba's path length limit; ``cache``: read and write the on-disk cache."""

    max_depth: int = param(16, range=(1, 1024), special={-1: "unbounded"}, unit="bounces",
                           help="Mitsuba's path length limit")
    cache: bool = param(True, help="read and write the on-disk cache of reference images")


class MitsubaReference(Technique):
    """Path-traced ground truth from Mitsuba 3 (path for specular views, ptracer for caustics)."""

    name = "mitsuba"
    summary = "Ground truth from Mitsuba 3: path tracing composited with light tracing for caustics (CPU, cached)"
    Params = MitsubaParams
    role = "reference"
    uses_gl = False
    square_spp = False  # Mitsuba's independent sampler takes any count

    def render(self, scene, camera, params, spp: int) -> np.ndarray:
        from ..reference.render import render_reference

        params = params if params is not None else MitsubaParams()
        return render_reference(scene, spp=spp, camera=camera, max_depth=params.max_depth, cache=params.cache)
