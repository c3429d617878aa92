"""Composition of a view technique and a caustic technique: ``depth-search+caustic-mapping``.

The caustic technique's passes (which write ``caustic_maps``) run after the
view technique's shadow maps and refractor buffers and before its surface
shading, which then adds the caustic irradiance on diffuse receivers. A
caustic technique named alone is composed with :data:`DEFAULT_VIEW`.

Caustics seen *through* a refractor are approximate: the view techniques look
refracted rays up in the environment, so a caustic on a receiver behind glass
shows only where the refraction technique samples that receiver.
"""
from __future__ import annotations

import dataclasses

from ..errors import TechniqueError, closest_name
from ..passes.surfaces import ShadeSurfaces
from .raster import RasterTechnique

DEFAULT_VIEW = "depth-search"  # the most accurate view technique without preprocessing


class CausticTechnique(RasterTechnique):
    """A technique that builds caustic maps; subclasses implement :meth:`caustic_passes`."""

    def caustic_passes(self, params) -> list:
        """Passes that read ``light_samples`` (and shadow maps) and write ``caustic_maps``."""
        raise NotImplementedError

    def build_passes(self, params):
        from .base import get_technique

        return compose_passes(get_technique(DEFAULT_VIEW), self, _shared_params(get_technique(DEFAULT_VIEW), params), params)


class Composite(RasterTechnique):
    """A view technique and a caustic technique rendered together."""

    def __init__(self, view: RasterTechnique, caustics: CausticTechnique):
        self.view, self.caustics = view, caustics
        self.name = f"{view.name}+{caustics.name}"
        self.summary = f"{view.name} for what the camera sees, {caustics.name} for caustics"

    def make_params(self, **values):
        """Each value goes to the technique(s) that have a parameter of that name."""
        view_fields = {f.name for f in dataclasses.fields(self.view.Params)}
        caustic_fields = {f.name for f in dataclasses.fields(self.caustics.Params)}
        for key in values:
            if key not in view_fields | caustic_fields:
                raise TechniqueError(
                    f"technique '{self.name}' has no parameter '{key}'{closest_name(key, view_fields | caustic_fields)}; "
                    f"its parameters are: {', '.join(sorted(view_fields | caustic_fields))}"
                )
        view_params = self.view.make_params(**{k: v for k, v in values.items() if k in view_fields})
        caustic_params = self.caustics.make_params(**{k: v for k, v in values.items() if k in caustic_fields})
        return view_params, caustic_params

    def build_passes(self, params):
        view_params, caustic_params = params
        return compose_passes(self.view, self.caustics, view_params, caustic_params)


def compose_passes(view: RasterTechnique, caustics: CausticTechnique, view_params, caustic_params) -> list:
    """The view's passes with the caustic passes inserted before its surface shading."""
    passes = view.build_passes(view_params)
    shade = next(i for i, p in enumerate(passes) if isinstance(p, ShadeSurfaces))
    return passes[:shade] + caustics.caustic_passes(caustic_params) + passes[shade:]


def _shared_params(view: RasterTechnique, caustic_params):
    """The view's default parameters, with any the caustic technique shares (e.g. shadow_map_size)."""
    view_fields = {f.name for f in dataclasses.fields(view.Params)}
    shared = {k: v for k, v in dataclasses.asdict(caustic_params).items() if k in view_fields}
    return view.make_params(**shared)


def composite_technique(name: str, lookup) -> Composite:
    """``view+caustics`` -> Composite, or a TechniqueError naming what is wrong."""
    parts = name.split("+")
    if len(parts) != 2 or not all(parts):
        raise TechniqueError(f"technique '{name}' must be 'view+caustics', e.g. 'depth-search+caustic-mapping'")
    view, caustics = lookup(parts[0]), lookup(parts[1])
    if isinstance(view, CausticTechnique) or not isinstance(view, RasterTechnique):
        raise TechniqueError(f"'{parts[0]}' cannot show the camera view in '{name}'; use env-map, image-space or depth-search")
    if not isinstance(caustics, CausticTechnique):
        raise TechniqueError(f"'{parts[1]}' makes no caustics in '{name}'; use a caustic technique after the '+'")
    return Composite(view, caustics)
