"""Technique base class and registry.

A technique is an ordered set of passes (or a CPU algorithm, for ``exact``),
its parameters as a validated dataclass, and a docstring citing its paper.
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

_REGISTRY: dict[str, type["Technique"]] = {}


@dataclasses.dataclass
class NoParams(Params):
    """A technique without parameters."""


class Technique:
    """One way of rendering a scene. Subclasses set ``name``, ``summary``, ``Params``."""

    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    Params: ClassVar[type] = NoParams
    uses_gl: ClassVar[bool] = True
    # Samples per pixel form a k x k grid (raster supersampling, exact's stratified rays), so spp must be
    # a square; False where any count is honoured (Mitsuba's sampler).
    square_spp: ClassVar[bool] = True
    # Prefixes of qualified parameters (``prefix.name``) this technique routes itself (``per-object``'s
    # techniques); a composite passes such parameters on to it whole.
    qualified_prefixes: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.name:
            _REGISTRY[cls.name] = cls

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


def technique_names() -> list[str]:
    _load_builtin()
    return sorted(_REGISTRY)


def get_technique(name: str) -> Technique:
    """A technique by name; ``view+caustics`` composes a view technique with a caustic technique. A
    Technique instance (one built in code, e.g. a Composite) is returned as it is."""
    _load_builtin()
    if isinstance(name, Technique):
        return name
    if not isinstance(name, str):
        raise TechniqueError(f"technique {short(name)} must be a technique name such as 'env-map'; "
                             "run 'caustica techniques' to list them")
    if "+" in name:
        from .composite import composite_technique

        return composite_technique(name, get_technique)
    if name not in _REGISTRY:
        raise TechniqueError(
            f"unknown technique {short(name)}{closest_name(name, _REGISTRY)}; run 'caustica techniques' to list them"
        )
    return _REGISTRY[name]()


_HELPER_MODULES = {"base", "raster", "composite"}


_LOADED = False


def _load_builtin() -> None:
    """Import every module of this package once: each technique registers itself by subclassing."""
    global _LOADED
    if _LOADED:
        return
    import importlib
    import pkgutil
    from pathlib import Path

    for info in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if info.name not in _HELPER_MODULES:
            importlib.import_module(f"{__package__}.{info.name}")
    _LOADED = True
