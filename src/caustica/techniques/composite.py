"""Composition of a view technique and a caustic technique: ``depth-search+caustic-mapping``.

The caustic technique's passes (which write ``caustic_maps`` or ``caustic_tiles``,
``passes/caustics/maps.py``) run after the view technique's shadow maps and before
the first view pass that reads what they write: the surface shading, which adds
the caustic irradiance on diffuse receivers, or (``impostors``) the impostor
textures, so that a caustic on a receiver seen through or in glass shows there
too. A caustic technique named alone is composed with :data:`DEFAULT_VIEW`.

Caustics seen *through* a refractor are approximate with the other view
techniques: they look refracted rays up in the environment, so a caustic on a
receiver behind glass shows only where the refraction technique samples that receiver.
"""
from __future__ import annotations

import dataclasses

from ..errors import TechniqueError, closest_name
from ..passes.shading.surfaces import ShadeSurfaces
from .raster import RasterTechnique
from .registry import get_technique

DEFAULT_VIEW = "depth-search"  # the most accurate view technique without preprocessing
SPLATS = ("auto", "compute", "points")  # caustic techniques' splat: compute shader, point sprites, or the GL's best
POINT_MAPS = ("frustum", "cube")  # point lights' caustic map: a fitted frustum (cube when too wide), or a cube


def _defined_in(params_class: type, name: str) -> type:
    """The dataclass in ``params_class``'s ancestry that declares the field ``name``."""
    return next(c for c in params_class.__mro__ if name in getattr(c, "__annotations__", {}))


def is_shared(view: RasterTechnique, caustics: RasterTechnique, name: str) -> bool:
    """A parameter both halves have means the same when both inherit it from one declaration
    (shadow_map_size from ShadowedParams, the impostor settings from ImpostorParams, ...)."""
    return _defined_in(view.Params, name) is _defined_in(caustics.Params, name)


class CausticTechnique(RasterTechnique):
    """A technique that builds caustic maps; subclasses implement :meth:`caustic_passes`."""

    role = "caustics"

    def caustic_passes(self, params) -> list:
        """Passes that read ``light_samples`` (and shadow maps) and write ``caustic_maps`` or ``caustic_tiles``."""
        raise NotImplementedError

    def composed_with(self, view: RasterTechnique) -> "Composite":
        """``view`` for what the camera sees with these caustics (``view+caustics``, registry.py)."""
        return Composite(view, self)

    def build_passes(self, params):
        view = get_technique(DEFAULT_VIEW)
        return compose_passes(view, self, _shared_params(view, self, params), params)


class Composite(RasterTechnique):
    """A view technique and a caustic technique rendered together."""

    def __init__(self, view: RasterTechnique, caustics: CausticTechnique):
        self.view, self.caustics = view, caustics
        self.qualified_prefixes = view.qualified_prefixes  # the view routes these itself (per-object)
        self.name = f"{view.name}+{caustics.name}"
        self.summary = f"{view.name} for what the camera sees, {caustics.name} for caustics"

    def make_params(self, **values):
        """Route each value to its technique: ``name`` where only one has it or both share its declaration
        (:func:`is_shared`), ``<technique>.name`` where both have unrelated parameters of that name."""
        halves = {self.view: {}, self.caustics: {}}
        fields = {t: {f.name for f in dataclasses.fields(t.Params)} for t in halves}
        prefixes = {t.name.replace("-", "_"): t for t in halves}
        routed = {p.replace("-", "_") for p in self.qualified_prefixes}
        for key, value in values.items():
            prefix, _, name = key.rpartition(".")
            if prefix and prefix.replace("-", "_") in routed:
                halves[self.view][key] = value  # the view routes it (per-object's own techniques)
                continue
            if prefix:
                technique = prefixes.get(prefix.replace("-", "_"))
                if technique is None:
                    raise TechniqueError(f"'{prefix}' in parameter '{key}' is not part of '{self.name}'; "
                                         f"use {' or '.join(t.name for t in halves)}")
                targets = [technique]
            else:
                targets = [t for t in halves if name in fields[t]]
                if len(targets) == 2 and not is_shared(self.view, self.caustics, name):
                    raise TechniqueError(f"both {self.view.name} and {self.caustics.name} have a parameter '{name}'; "
                                         f"write {self.view.name}.{name} or {self.caustics.name}.{name}")
            if not targets:
                known = fields[self.view] | fields[self.caustics]
                raise TechniqueError(f"technique '{self.name}' has no parameter '{name}'{closest_name(name, known)}; "
                                     f"its parameters are: {', '.join(sorted(known))}")
            for technique in targets:
                halves[technique][name] = value
        return self.view.make_params(**halves[self.view]), self.caustics.make_params(**halves[self.caustics])

    def build_passes(self, params):
        view_params, caustic_params = params
        return compose_passes(self.view, self.caustics, view_params, caustic_params)


def compose_passes(view: RasterTechnique, caustics: CausticTechnique, view_params, caustic_params) -> list:
    """The view's passes with the caustic passes inserted before the first view pass that reads
    (or optionally reads) what they write: the surface shading, or the impostors whose textures
    show the caustics."""
    passes = view.build_passes(view_params)
    caustic = caustics.caustic_passes(caustic_params)
    made = {c.name for p in caustic for c in p.writes}
    first = next(i for i, p in enumerate(passes)
                 if isinstance(p, ShadeSurfaces) or made & {*p.reads, *p.optional})
    return passes[:first] + caustic + passes[first:]


def _shared_params(view: RasterTechnique, caustics: RasterTechnique, caustic_params):
    """The view's default parameters, with the ones both declare alike (:func:`is_shared`) from the caustic technique."""
    view_fields = {f.name for f in dataclasses.fields(view.Params)}
    shared = {k: v for k, v in dataclasses.asdict(caustic_params).items()
              if k in view_fields and is_shared(view, caustics, k)}
    return view.make_params(**shared)
