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
from ..scene import rules

if TYPE_CHECKING:  # pragma: no cover
    from ..renderer import Renderer
    from ..scene import Camera, Scene

_REGISTRY: dict[str, type["Technique"]] = {}


@dataclasses.dataclass
class NoParams:
    """A technique without parameters."""


def check_integers(params, ranges: dict) -> None:
    """Each field ``name: (low, high)`` of ``params`` must be an integer (not a bool, a string or inf) in
    [low, high]; stored as int. A TechniqueError names the field otherwise (parameter dataclasses' __post_init__)."""
    for name, (low, high) in ranges.items():
        setattr(params, name, rules.integer(getattr(params, name), name, low, high, error=TechniqueError))


def check_numbers(params, ranges: dict) -> None:
    """Each field ``name: (low, high)`` or ``(low, high, ends)`` of ``params`` must be a finite number (not a
    bool or a string) in the range, ``ends`` one of "[]" (the default), "(]", "[)", "()"; stored as float.
    A TechniqueError names the field and its range otherwise."""
    for name, (low, high, *ends) in ranges.items():
        ends = ends[0] if ends else "[]"
        setattr(params, name, rules.number(getattr(params, name), name, low, high, open_low=ends[0] == "(",
                                           open_high=ends[1] == ")", error=TechniqueError))


def check_flags(params, names) -> None:
    """Each field in ``names`` must be true or false (not 'yes', not 1); stored as bool."""
    for name in names:
        setattr(params, name, rules.flag(getattr(params, name), name, error=TechniqueError))


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

    def render(self, renderer: "Renderer", scene: "Scene", camera: "Camera", params, spp: int) -> np.ndarray:
        """Return a (H, W, 3) float32 linear image, row 0 at the top."""
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
    """A technique by name; ``view+caustics`` composes a view technique with a caustic technique."""
    _load_builtin()
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
