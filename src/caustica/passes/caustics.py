"""The contract between caustic techniques and the surface-shading pass.

A caustic technique's passes write the channel ``caustic_maps``: one
:class:`CausticMap` per light sample (in the order of ``light_samples``), or
None for a light that makes no caustic. A texel holds the irradiance (W/m^2,
RGB) that light focused by refractors or reflectors delivers to the receiver
surface the texel sees from the light, and in alpha that surface's distance to
the light (dot with the direction for directional lights; 0 where empty).
``ShadeSurfaces`` adds it to the diffuse irradiance when the channel exists
(``shaders/common/caustics.glsl``).

Or it writes ``caustic_tiles`` (:class:`CausticTiles`, Hu and Qin 3.3): caustic
textures on rectangles between casters and receivers, which each receiver
fragment looks up by the rectangles' parallel projections as it is shaded.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..gpu.meshes import set_uniform, write_uniform_array
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


MAX_CAUSTIC_TILES = 16  # rectangles whose caustic textures one frame can carry (impostor_caustic_filter.comp's texel_area[16])


@dataclass
class CausticTiles:
    """Caustic textures on rectangles (Hu and Qin 3.2-3.3): irradiance across each rectangle's axis,
    side by side in one rgba32f atlas; ``receivers[k]`` is the object tile k's rectangle stands for."""

    texture: object
    tile_size: int
    clip_from_world: np.ndarray  # (N, 4, 4): each rectangle's parallel projection
    axes: np.ndarray  # (N, 3): unit projection axes, from the caster towards the receiver
    receivers: list
    texel_areas: np.ndarray  # (N,): area one texel covers on each rectangle (scene units squared)

    def tiles_of(self, obj) -> list[int]:
        """The tiles lying on ``obj``."""
        return [k for k, receiver in enumerate(self.receivers) if receiver is obj]


def bind_caustic_tiles(program, tiles: CausticTiles, unit: int) -> None:
    """Set caustics.glsl's tile uniforms shared by every receiver and bind the atlas to ``unit``."""
    count = min(len(tiles.receivers), MAX_CAUSTIC_TILES)
    clips = np.tile(np.eye(4, dtype="f4"), (MAX_CAUSTIC_TILES, 1, 1))
    axes = np.zeros((MAX_CAUSTIC_TILES, 3), "f4")
    clips[:count], axes[:count] = tiles.clip_from_world[:count], tiles.axes[:count]
    tiles.texture.use(unit)
    set_uniform(program, "caustic_tiles", unit)
    set_uniform(program, "caustic_tile_size", int(tiles.tile_size))
    write_uniform_array(program, "caustic_tile_clip_from_world", np.ascontiguousarray(clips.transpose(0, 2, 1)))
    write_uniform_array(program, "caustic_tile_axis", axes)


def bind_receiver_tiles(program, tiles: CausticTiles, obj) -> None:
    """Which tiles the receiver ``obj`` (about to be drawn) looks up."""
    mine = [k for k in tiles.tiles_of(obj) if k < MAX_CAUSTIC_TILES]
    order = np.zeros(MAX_CAUSTIC_TILES, "i4")
    order[: len(mine)] = mine
    write_uniform_array(program, "receiver_tile", order)
    set_uniform(program, "receiver_tile_count", len(mine))

