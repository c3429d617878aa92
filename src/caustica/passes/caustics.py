"""The contract between caustic techniques and the surface-shading pass.

A caustic technique's passes write the channel ``caustic_maps``: one
:class:`CausticMap` per light sample (in the order of ``light_samples``), or
None for a light that makes no caustic. A texel holds the irradiance (W/m^2,
RGB) that light focused by refractors or reflectors delivers to the receiver
surface the texel sees from the light, and in alpha that surface's distance to
the light (dot with the direction for directional lights; 0 where empty).
``ShadeSurfaces`` adds it to the diffuse irradiance when the channel exists
(``shaders/common/caustics.glsl``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..gpu.meshes import set_uniform
from .lights import MAX_LIGHTS

CAUSTIC_NONE, CAUSTIC_PROJECTIVE, CAUSTIC_CUBE = 0, 1, 2


@dataclass
class CausticMap:
    """One light's caustic map: an rgba32f texture and how receivers find their texel."""

    texture: object
    kind: int  # CAUSTIC_PROJECTIVE (clip_from_world) or CAUSTIC_CUBE (six-face atlas, 6N x N)
    clip_from_world: np.ndarray | None = None


def bind_caustic_maps(program, maps: list, first_unit: int, distance_tolerance: float = 5e-3) -> None:
    """Set the caustics.glsl uniforms and bind the maps from texture unit ``first_unit``."""
    kinds = np.zeros(MAX_LIGHTS, dtype="i4")
    clips = np.tile(np.eye(4, dtype="f4"), (MAX_LIGHTS, 1, 1))
    units = np.full(MAX_LIGHTS, first_unit, dtype="i4")
    for i, caustic in enumerate(maps[:MAX_LIGHTS]):
        if caustic is None:
            continue
        kinds[i] = caustic.kind
        if caustic.clip_from_world is not None:
            clips[i] = caustic.clip_from_world
        caustic.texture.use(first_unit + i)
        units[i] = first_unit + i
    set_uniform(program, "caustic_kind", kinds)
    if "caustic_clip_from_world" in program:
        program["caustic_clip_from_world"].write(np.ascontiguousarray(clips.transpose(0, 2, 1)).tobytes())
    if "caustic_map" in program:
        program["caustic_map"].write(units.tobytes())
    set_uniform(program, "caustic_distance_tolerance", float(distance_tolerance))
