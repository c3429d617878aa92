"""The Technique base class: what every technique declares.

A technique is an ordered set of passes (or a CPU algorithm, for ``exact``),
its parameters as a validated dataclass, and a docstring citing its paper. It
declares its name and its role as class attributes; techniques/registry.py
finds every declared technique and derives the lists of view and caustic
techniques from these declarations.
"""
from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from ..errors import TechniqueError, closest_name, short
from ..parameters import Params, param  # noqa: F401 (the techniques declare with these)

if TYPE_CHECKING:  # pragma: no cover
    from ..scene import Camera, Scene

# What a technique does in a render, and where it may stand in a ``view+caustics`` name.
ROLES = {
    "view": "renders what the camera sees with GPU passes; stands before the '+' of a composite",
    "caustics": "builds caustic maps (CausticTechnique); stands after the '+', or alone with the default view",
    "planner": "chooses another technique for each scene (auto)",
    "reference": "renders on the CPU what the others are measured against (exact, mitsuba)",
}


@dataclasses.dataclass
class NoParams(Params):
    """A technique without parameters."""


class Technique:
    """One way of rendering a scene. Subclasses set ``name``, ``summary``, ``Params`` and ``role``."""

    name: ClassVar[str] = ""  # a class that declares a name is a technique of the registry
    summary: ClassVar[str] = ""
    Params: ClassVar[type] = NoParams
    role: ClassVar[str] = ""  # one of ROLES; RasterTechnique declares "view", CausticTechnique "caustics"
    # A view technique whose passes end in one ShadeSurfaces that per-object can restrict to some objects
    # declares its place among the view techniques: per-object offers those, the composites' messages name
    # them, in this order (lowest first).
    view_order: ClassVar[int | None] = None
    uses_gl: ClassVar[bool] = True
    # Samples per pixel form a k x k grid (raster supersampling, exact's stratified rays), so spp must be
    # a square; False where any count is honoured (Mitsuba's sampler).
    square_spp: ClassVar[bool] = True
    # Prefixes of qualified parameters (``prefix.name``) this technique routes itself (``per-object``'s
    # techniques); a composite passes such parameters on to it whole.
    qualified_prefixes: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, **kwargs):
        """A declared technique's role must be one of ROLES; only a view technique takes a view_order."""
        super().__init_subclass__(**kwargs)
        if "name" not in vars(cls):
            return
        if cls.role not in ROLES:
            raise TypeError(f"technique '{cls.name}' declares role {cls.role!r}; give one of {', '.join(ROLES)}")
        if cls.view_order is not None and cls.role != "view":
            raise TypeError(f"technique '{cls.name}' declares a view_order but its role is {cls.role!r}, not 'view'")

    def make_params(self, **values: Any):
        """Build the parameter dataclass, rejecting unknown names with a hint."""
        fields = {f.name for f in dataclasses.fields(self.Params)}
        for key in values:
            if key not in fields:
                raise TechniqueError(
                    f"technique '{self.name}' has no parameter {short(key)}{closest_name(key, fields)}; "
                    f"its parameters are: {', '.join(sorted(fields)) or 'none'}"
                )
        try:
            return self.Params(**values)
        except (TypeError, ValueError) as exc:
            raise TechniqueError(f"technique '{self.name}': {exc}") from None

    def for_scene(self, scene: "Scene", params, frame_ms=None, frame_size=None):
        """The technique and parameters that render ``scene``: itself, or what a planner (``auto``)
        chooses for it; ``frame_ms(technique, params)``, when given, measures a candidate;
        ``frame_size``: the (supersampled) pixels of the frame it renders."""
        return self, params

    def render(self, scene: "Scene", camera: "Camera", params, spp: int) -> np.ndarray:
        """A CPU technique's (``uses_gl`` False) (H, W, 3) float32 linear image, row 0 at the top; a
        rasterized technique lists passes instead (raster.py), which the renderer runs."""
        raise NotImplementedError


def check_spp(technique: "Technique", spp: int) -> None:
    """TechniqueError unless ``technique`` renders exactly ``spp`` samples per pixel: a k x k grid takes
    only squares (2 would render 1, 3 would render 4)."""
    if not technique.square_spp or spp < 1:
        return
    k = math.isqrt(int(spp))
    if k * k != spp:
        raise TechniqueError(
            f"spp {spp} is not a square; '{technique.name}' takes k x k samples per pixel: "
            f"use {k * k} or {(k + 1) ** 2} (any of 1, 4, 9, 16, ...)"
        )
