"""Light samples and shadow maps (distance maps) for diffuse receivers.

Directional lights: orthographic map fitted around the scene. Spot lights: a
perspective map over the outer cone. Point lights (and each point of a line
light): a six-face atlas, 6N x N, in the face layout of ``CUBE_FORWARD`` /
``CUBE_UP``. Every map stores the distance to the light in r32f. Receivers
(common/lighting.glsl) filter 3x3 texels, comparing each texel's distance with
where that texel's ray from the light meets the receiver's tangent plane, moved
SHADOW_NORMAL_OFFSET texel widths along the normal: no self-shadowing at grazing
angles, and the shadow of an occluder resting on the receiver stays attached.
"""
from __future__ import annotations

import moderngl
import numpy as np

from ...cache import material_state_key, scene_state_key
from ...gpu.meshes import set_uniform
from ...gpu.shaders import run_compute
from ...lighting.bake import bake_atlas, scene_bake
from ...lighting.environment import environment_lobes, floor_bounce_sh, mean_albedo, scene_floor
from ...lighting.samples import CUBE_FORWARD, CUBE_UP, MAX_LIGHTS, LightSample, directional_sample, light_samples
from ...render.bindings import bind_lights
from ...render.draw import draw_objects
from ...render.frame import Channel, Frame, Pass
from ...scene.codes import LIGHT_DIRECTIONAL, LIGHT_POINT
from ...scene.lights import DirectionalLight
from ...scene.transform import look_at_view_from_world, perspective_clip_from_view
from .environment import EnvironmentBake, EnvironmentShadows, bake_settings, lobe_settings


class ShadowMaps(Pass):
    """Distance-to-light maps for every light sample (reused while lights and objects stay put), and, where
    the frame's parameters ask for ``environment_lobes`` (auto sets it), the environment's lobes' directional
    maps side by side in one atlas (passes/shading/environment.py)."""

    reads = ()
    writes = (
        Channel("light_samples", "host[light]", "point/directional/spot samples with their shadow projections"),
        Channel("shadow_maps", "r32f[light]", "per light sample: distance to the light (6-face atlas for points)"),
        Channel("environment_shadows", "host", "EnvironmentShadows: the environment's lobes and their maps' atlas, "
                                               "or None"),
        Channel("environment_bake", "host", "EnvironmentBake: the light maps and per-vertex irradiance of the "
                                            "ambient environment on the diffuse receivers (rgba32f atlas), or None"),
    )

    def __init__(self, size: int = 1024):
        self.size = size

    def cache_key(self, frame: Frame):
        lobes, bake = lobe_settings(frame.params), bake_settings(frame.params)
        # The lobes' maps and the floor's light map tell glass from opaque objects and hold the glass's IOR and
        # absorption and the objects' colours.
        return (self.size, lobes, bake, scene_state_key(frame.scene),
                material_state_key(frame.scene) if lobes[0] or bake else ())

    def run(self, frame: Frame) -> None:
        samples = light_samples(frame.scene)
        maps = [self._render(frame, [s], frame.scene.objects) for s in samples]
        frame.write("light_samples", samples)
        frame.write("shadow_maps", maps)
        frame.write("environment_shadows", self._environment_shadows(frame, samples, maps))
        frame.write("environment_bake", self._environment_bake(frame, samples))

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
        floor = scene_floor(scene)
        ground = None if floor is None else floor_bounce_sh(scene.environment, sun_taken, mean_albedo(floor))
        return EnvironmentBake(texture, bake.maps, tiles, ground, table_row, vertex_row, objects,
                               tuple((id(o), entry) for o, entry in zip(scene.objects, objects)), rectangles)

    def _environment_shadows(self, frame: Frame, samples: list[LightSample], maps: list):
        count, size = lobe_settings(frame.params)
        if not count:
            return None
        scene = frame.scene
        sun_taken = any(s.environment for s in samples)
        lobes = environment_lobes(scene.environment, sun_taken, count)
        floor = scene_floor(scene)
        ground = None if floor is None else floor_bounce_sh(scene.environment, sun_taken, mean_albedo(floor))
        center = scene.bounds().mean(axis=0)
        radius = 0.5 * np.linalg.norm(np.ptp(scene.bounds(), axis=0)) + 1e-6
        tiles = [directional_sample(DirectionalLight(d, np.ones(3)), center, radius) for d in lobes.directions]
        # Opaque casters stop a lobe; glass lets through its transmittance (tinted, soft shadows): the glass's
        # nearest distance and its optical depth along each lobe, in one more atlas.
        opaque = [o for o in scene.objects if o.material.kind != "glass"]
        glass = [o for o in scene.objects if o.material.kind == "glass"]
        atlas = self._render(frame, tiles, opaque, size)
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

    def _render(self, frame: Frame, samples: list[LightSample], objects, size: int | None = None):
        """One map: a point sample's six-face atlas, or the directional and spot ``samples`` as tiles side by side."""
        ctx, gpu, n = frame.gpu.ctx, frame.gpu, size or self.size
        sample = samples[0]
        faces = 6 if sample.type == LIGHT_POINT else len(samples)
        color = frame.own(ctx.texture((n * faces, n), 1, dtype="f4"))  # nearest filtered, unlike pooled ones
        depth = frame.own(ctx.depth_renderbuffer((n * faces, n)))
        fbo = frame.own(ctx.framebuffer([color], depth))
        along = 1 if sample.type == LIGHT_DIRECTIONAL else 0
        program = gpu.shaders.program("common/mesh_vertex.glsl", "passes/shading/distance.frag", {"ALONG_DIRECTION": along})
        fbo.use()
        fbo.clear(1e30, 1e30, 1e30, 1e30, depth=1.0)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)
        radius = 0.5 * np.linalg.norm(np.ptp(frame.scene.bounds(), axis=0)) + 1e-6
        for face in range(faces):
            fbo.viewport = (face * n, 0, n, n)
            if sample.type == LIGHT_POINT:
                p = sample.position
                view = look_at_view_from_world(p, p + CUBE_FORWARD[face], CUBE_UP[face])
                far = np.linalg.norm(p - frame.scene.bounds().mean(axis=0)) + 2 * radius
                clip = perspective_clip_from_view(90.0, 1.0, 1e-3 * radius, far) @ view
            else:
                sample = samples[face]
                clip = sample.clip_from_world
            set_uniform(program, "origin", sample.position.astype("f4"))
            set_uniform(program, "direction", sample.direction.astype("f4"))
            draw_objects(frame, program, objects, clip)
        color.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return color


