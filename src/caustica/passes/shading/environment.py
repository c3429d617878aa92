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
shadow maps (EnvironmentLobeMaps below draws them), glass passing its transmittance, the blocked sky
showing the occluders' bounce, and a floor's bounce for the light from below (docs/environment-light.md).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import moderngl
import numpy as np

from ...cache import material_state_key, scene_state_key
from ...gpu.meshes import set_uniform
from ...gpu.shaders import run_compute
from ...lighting.bake import MAX_BAKE_SIZE, MAX_OBJECT_RECTS, TABLE_TEXELS, bake_atlas, scene_bake
from ...lighting.environment import (LOBE_MAP_SIZE, MAX_LOBES, EnvironmentLobes, environment_lobes, floor_bounce_sh,
                                     ground_sh, mean_albedo)
from ...lighting.samples import MAX_LIGHTS, LightSample, directional_sample, scene_sphere
from ...render.bindings import bind_lights
from ...render.draw import draw_objects
from ...render.frame import Channel, Frame, Pass, frame_setting
from ...scene.lights import DirectionalLight
from .shadows import distance_map

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
    """EnvironmentLobeMaps' ``environment_shadows``: the lobes, their directional samples (passes/shading/shadows.py's
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
        bound (EnvironmentLobeMaps always draws the bounce; bench_environment_light measures without it)."""
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
    """EnvironmentLightMaps' ``environment_bake``: the scene's bake (:class:`SceneBake`) in one rgba32f ``texture`` (the
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
        state the bake's is: EnvironmentLightMaps' cache key) or in a part of it (a view without some objects)."""
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


class EnvironmentLobeMaps(Pass):
    """The environment's lobes (lighting/environment.py) where the frame's parameters ask for
    ``environment_lobes`` (auto sets it): their directional maps side by side in one atlas, the glass along
    them, the occluders' bounce and the nearest distances (docs/environment-light.md); None otherwise."""

    reads = ("light_samples", "shadow_maps")
    writes = (Channel("environment_shadows", "host", "EnvironmentShadows: the environment's lobes and their maps' "
                                                     "atlas, or None"),)

    def cache_key(self, frame: Frame):
        lobes = lobe_settings(frame.params)
        # The lobes' maps tell glass from opaque objects and hold the glass's IOR and absorption and the colours.
        return (lobes, scene_state_key(frame.scene), material_state_key(frame.scene) if lobes[0] else ())

    def run(self, frame: Frame) -> None:
        frame.write("environment_shadows",
                    self._environment_shadows(frame, frame.read("light_samples"), frame.read("shadow_maps")))

    def _environment_shadows(self, frame: Frame, samples: list[LightSample], maps: list):
        count, size = lobe_settings(frame.params)
        if not count:
            return None
        scene = frame.scene
        sun_taken = any(s.environment for s in samples)
        lobes = environment_lobes(scene.environment, sun_taken, count)
        ground = ground_sh(scene, sun_taken)
        center, radius = scene_sphere(scene)
        tiles = [directional_sample(DirectionalLight(d, np.ones(3)), center, radius) for d in lobes.directions]
        # Opaque casters stop a lobe; glass lets through its transmittance (tinted, soft shadows): the glass's
        # nearest distance and its optical depth along each lobe, in one more atlas.
        opaque = [o for o in scene.objects if o.material.kind != "glass"]
        glass = [o for o in scene.objects if o.material.kind == "glass"]
        atlas = distance_map(frame, tiles, opaque, size)
        sky_only = floor_bounce_sh(scene.environment, sun_taken, np.zeros(3))
        bounce = self._bounce(frame, tiles, opaque, size, samples, maps, sky_only)
        glass_atlas = self._glass(frame, tiles, glass, size) if glass else None
        return EnvironmentShadows(atlas, tiles, lobes, glass_atlas, ground, bounce,
                                  self._nearest(frame, atlas, glass_atlas, size))

    def _nearest(self, frame: Frame, atlas, glass_atlas, size: int):
        """rg32f: per lobe texel the nearest opaque and glass distance over its 3x3 taps (lobe_nearest.comp)."""
        ctx = frame.gpu.ctx
        target = frame.own(ctx.texture(atlas.size, 2, dtype="f4"))
        program = frame.gpu.shaders.compute("passes/shading/lobe_nearest.comp")
        atlas.use(0)
        (glass_atlas or atlas).use(1)
        set_uniform(program, "opaque", 0)
        set_uniform(program, "glass", 1)
        set_uniform(program, "has_glass", int(glass_atlas is not None))
        set_uniform(program, "tile_size", size)
        target.bind_to_image(0, read=False, write=True)
        run_compute(program, (atlas.size[0] + 7) // 8, (atlas.size[1] + 7) // 8)
        ctx.memory_barrier()
        target.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return target

    def _bounce(self, frame: Frame, tiles: list[LightSample], opaque, size: int, samples, maps, sky_sh):
        """Per lobe texel (rgba32f atlas), the radiance of the nearest opaque surface facing along the lobe
        (lobe_bounce.frag), lit by ``samples`` through their shadow ``maps`` and by ``sky_sh``; 0 where none."""

        ctx = frame.gpu.ctx
        target = frame.own(ctx.texture((size * len(tiles), size), 4, dtype="f4"))
        fbo = frame.own(ctx.framebuffer([target], frame.own(ctx.depth_renderbuffer((size * len(tiles), size)))))
        program = frame.gpu.shaders.program("common/mesh_vertex.glsl", "passes/shading/lobe_bounce.frag",
                                            {"MAX_LIGHTS": MAX_LIGHTS})
        bind_lights(program, samples, maps)
        set_uniform(program, "irradiance_sh", sky_sh.astype("f4"))
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)
        for k, tile in enumerate(tiles):
            fbo.viewport = (k * size, 0, size, size)
            set_uniform(program, "direction", tile.direction.astype("f4"))
            for obj in opaque:
                set_uniform(program, "albedo", mean_albedo(obj).astype("f4"))
                draw_objects(frame, program, [obj], tile.clip_from_world)
        target.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return target

    def _glass(self, frame: Frame, tiles: list[LightSample], glass, size: int):
        """The glass along each directional tile (glass_optical_depth.frag), rgba32f: rgb its optical depth
        per channel (every face of every glass object summed with additive blending), a its nearest distance
        (MIN blending); no depth test."""
        ctx = frame.gpu.ctx
        target = frame.own(ctx.texture((size * len(tiles), size), 4, dtype="f4"))
        fbo = frame.own(ctx.framebuffer([target]))
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 1e30)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        try:
            for nearest, equation in ((0, moderngl.FUNC_ADD), (1, moderngl.MIN)):
                ctx.blend_equation = equation
                program = frame.gpu.shaders.program("common/mesh_vertex.glsl", "passes/shading/glass_optical_depth.frag",
                                                    {"NEAREST_DISTANCE": nearest})
                for k, tile in enumerate(tiles):
                    fbo.viewport = (k * size, 0, size, size)
                    set_uniform(program, "origin", tile.position.astype("f4"))
                    set_uniform(program, "direction", tile.direction.astype("f4"))
                    for obj in glass:
                        set_uniform(program, "sigma", obj.material.absorption_coefficient.astype("f4"))
                        set_uniform(program, "ior", obj.material.ior_rgb.astype("f4"))
                        set_uniform(program, "solid", float(obj.mesh.is_solid()))
                        draw_objects(frame, program, [obj], tile.clip_from_world)
        finally:
            ctx.blend_equation = moderngl.FUNC_ADD
            ctx.disable(moderngl.BLEND)
            ctx.blend_func = moderngl.DEFAULT_BLENDING
        target.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return target


class EnvironmentLightMaps(Pass):
    """The light maps and per-vertex irradiance of the environment's light on the diffuse receivers
    (lighting/bake.py), in one rgba32f atlas, where the frame's parameters ask for ``environment_bake``
    and the scene has a diffuse receiver; None otherwise."""

    reads = ("light_samples",)
    writes = (Channel("environment_bake", "host", "EnvironmentBake: the light maps and per-vertex irradiance of the "
                                                  "ambient environment on the diffuse receivers (rgba32f atlas), or None"),)

    def cache_key(self, frame: Frame):
        bake = bake_settings(frame.params)
        # The light maps tell glass from opaque objects and hold the glass's IOR and absorption and the colours.
        return (bake, scene_state_key(frame.scene), material_state_key(frame.scene) if bake else ())

    def run(self, frame: Frame) -> None:
        frame.write("environment_bake", self._environment_bake(frame, frame.read("light_samples")))

    def _environment_bake(self, frame: Frame, samples: list[LightSample]):
        """The light maps (environment_lights.scene_bake) where the frame's parameters ask for them and the scene
        has a diffuse receiver, else None."""
        size = bake_settings(frame.params)
        scene = frame.scene
        sun_taken = any(s.environment for s in samples)
        bake = scene_bake(scene, sun_taken, size) if size else None
        if bake is None or not (bake.maps or any(v is not None for v in bake.vertices)):
            return None
        image, rectangles, table_row, vertex_row, objects, tiles = bake_atlas(bake)
        texture = frame.own(frame.gpu.ctx.texture(image.shape[1::-1], 4, image.tobytes(), dtype="f4"))
        texture.repeat_x = texture.repeat_y = False
        ground = ground_sh(scene, sun_taken)
        return EnvironmentBake(texture, bake.maps, tiles, ground, table_row, vertex_row, objects,
                               tuple((id(o), entry) for o, entry in zip(scene.objects, objects)), rectangles)


