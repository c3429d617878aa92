"""The environment's light in the raster techniques: its sun as a directional light, the rest as SH.

A small, very bright region of the environment (a sun) lights diffuse surfaces through a sharp shadow and
focuses through glass into a caustic; the unoccluded SH irradiance (Ramamoorthi and Hanrahan 2001) the
raster techniques give diffuse surfaces has neither. So at frame setup the sun is taken out of the
environment as a :class:`~caustica.scene.lights.DirectionalLight` that goes through the same shadow-map and
caustic-map machinery as the scene's lights (``passes/shading/shadows.py``: ``light_samples`` appends it, flagged
``environment``), and the diffuse ambient becomes the SH irradiance of the rest. Glass and mirrors still
look the sun up in the environment; users' ``scene.lights`` never see it. docs/environment-light.md.

The bright region is the one ``exact`` samples (:class:`~caustica.raytrace.environment_light.EnvironmentLight`:
texels above ``BRIGHT_RATIO`` times the mean radiance); the split adds up to the original image exactly.
The light's irradiance is the bright part's radiance integrated over solid angle (per channel), its
direction of travel minus the power-weighted mean direction, both estimated from SUN_SAMPLES stratified
samples of ``EnvironmentLight.sample_bright`` (which samples by power, so the estimate is near exact). A
bright part spread wider than SUN_SPREAD degrees (several suns, a window) is no sun: it stays in the SH.

Part 2 (where auto asks for ``environment_lobes``): the rest of the sky as strata of equal power with
shadow maps (passes/shading/shadows.py ShadowMaps draws them), glass passing its transmittance, the blocked sky
showing the occluders' bounce, and a floor's bounce for the light from below (docs/environment-light.md).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...lighting.bake import MAX_BAKE_SIZE, MAX_OBJECT_RECTS, TABLE_TEXELS
from ...lighting.environment import LOBE_MAP_SIZE, MAX_LOBES, EnvironmentLobes
from ...render.frame import frame_setting

# Part 2: the rest of the environment's light, occluded -------------------------------------------------


# The floor's bounce: the ground's light for diffuse surfaces --------------------------------------------


def lobe_settings(params) -> tuple[int, int]:
    """(lobes, texels a side of each map) a frame's parameters ask for: the ``environment_lobes`` and
    ``environment_lobe_size`` attributes auto sets on the planned technique's parameters (on the view's of a
    composite's pair), else (0, LOBE_MAP_SIZE)."""
    count = int(frame_setting(params, "environment_lobes") or 0)
    if not 0 <= count <= MAX_LOBES:
        raise ValueError(f"environment_lobes must be 0 to {MAX_LOBES} (got {count})")
    return count, int(frame_setting(params, "environment_lobe_size") or LOBE_MAP_SIZE)


@dataclass
class EnvironmentShadows:
    """ShadowMaps' ``environment_shadows``: the lobes, their directional samples (passes/shading/shadows.py's
    LightSample, one tile each) and the atlas of their opaque objects' distance maps (r32f, K N x N); where
    the scene has glass, the atlas of the glass along each lobe (rgba32f: rgb its optical depth, -log of its
    transmittance per channel, a its nearest distance; passes/shading/glass_optical_depth.frag), else None."""

    atlas: object
    tiles: list
    lobes: EnvironmentLobes
    glass: object = None
    ambient_sh: np.ndarray | None = None  # (9, 3): floor_bounce_sh where the scene has a floor, else None
    bounce: object = None  # rgba32f atlas: per lobe texel, the radiance a receiver behind the occluder sees
    nearest: object = None  # rg32f atlas: per lobe texel, the nearest opaque and glass distance over its taps

    def defines(self) -> dict[str, int]:
        """lighting.glsl's ENVIRONMENT_GLASS and ENVIRONMENT_BOUNCE: 1 where the glass's, the bounce's atlas is
        bound (ShadowMaps always draws the bounce; bench_environment_light measures without it)."""
        return {"ENVIRONMENT_GLASS": int(self.glass is not None), "ENVIRONMENT_BOUNCE": int(self.bounce is not None)}


# The light maps: the ambient environment's light on the diffuse receivers, baked with exact's rays -----------


def bake_settings(params) -> int:
    """Texels a side of the floor's light map the frame's parameters ask for (``environment_bake``, which auto
    sets on the planned technique's parameters); 0: none."""
    size = int(frame_setting(params, "environment_bake") or 0)
    if not 0 <= size <= MAX_BAKE_SIZE:
        raise ValueError(f"environment_bake must be 0 to {MAX_BAKE_SIZE} texels (got {size})")
    return size


@dataclass
class EnvironmentBake:
    """ShadowMaps' ``environment_bake``: the scene's bake (:class:`SceneBake`) in one rgba32f ``texture`` (the
    maps' ``tiles``, x0, y0, columns, rows in texels each; below them the rectangles' table from row
    ``table_row``, rectangle_rows, TABLE_TEXELS a row; below that the vertices' irradiance from row ``vertex_row``,
    row-major),
    per scene object (in the scene's order) its maps' range and its vertices' first index in that region (-1:
    none), and the SH ambient of every other diffuse surface (floor_bounce_sh where there is a floor, else None)."""

    texture: object
    maps: list
    tiles: np.ndarray
    ambient_sh: np.ndarray | None
    table_row: int = 0
    vertex_row: int = 0
    objects: tuple = ()  # per scene object: (first map, map count, first vertex or -1)
    by_id: tuple = ()  # (id(scene object), its entry) of the scene the bake was made for
    rectangles: np.ndarray | None = None  # rectangle_rows of the maps: what bind_baked_object gives an object
    _uniforms: dict = field(default_factory=dict, repr=False)  # id(object) -> object_uniforms

    @property
    def has_vertices(self) -> bool:
        return any(entry[2] >= 0 for entry in self.objects)

    def pooled(self) -> list:
        """Its one GL object, the atlas (gpu.device.gl_objects: the graph looks for lent textures in every live
        channel after every pass, and the rest of this bake is host data it need not walk)."""
        return [self.texture]

    def entry(self, scene, obj) -> tuple[int, int, int]:
        """``obj``'s (first map, map count, first vertex or -1) by its place in ``scene`` (the frame's, whose
        state the bake's is: ShadowMaps' cache key) or in a part of it (a view without some objects)."""
        index = next((i for i, o in enumerate(scene.objects) if o is obj), None)
        if index is not None and len(scene.objects) == len(self.objects):
            return self.objects[index]
        return dict(self.by_id).get(id(obj), (0, 0, -1))

    def object_uniforms(self, scene, obj) -> tuple[np.ndarray, int, int]:
        """(env_bake_rect's rows, env_bake_rect_count, env_bake_vertex_first) of ``obj`` (bind_baked_object),
        worked out once per object: a frame binds them at every draw of every pass."""
        kept = self._uniforms.get(id(obj))
        if kept is None:
            first, count, vertex = self.entry(scene, obj)
            if count > MAX_OBJECT_RECTS:
                raise ValueError(f"an object has {count} light maps; lighting.glsl takes {MAX_OBJECT_RECTS}")
            rows = np.zeros((MAX_OBJECT_RECTS * TABLE_TEXELS, 4), np.float32)
            rows[:count * TABLE_TEXELS] = self.rectangles[first:first + count].reshape(-1, 4)
            kept = self._uniforms[id(obj)] = (rows, count, vertex)
        return kept


