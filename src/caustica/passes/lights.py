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

import dataclasses
from dataclasses import dataclass

import moderngl
import numpy as np

from ..cache import material_state_key, scene_state_key, state_key  # noqa: F401 (scene_state_key re-exported)
from ..errors import TechniqueError
from ..gpu.meshes import set_object_transform, set_uniform
from ..gpu.shaders import run_compute
from ..scene.codes import LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT
from ..scene.lights import DirectionalLight, SpotLight
from ..scene.transform import (
    look_at_view_from_world,
    orthographic_clip_from_view,
    perspective_clip_from_view,
    up_hint,
)
from ..render.frame import Channel, Frame, Pass
from .environment_lights import (EnvironmentBake, EnvironmentShadows, bake_atlas, bake_settings, environment_lobes,
                                 environment_sun, floor_bounce_sh, lobe_settings, mean_albedo, scene_bake,
                                 scene_floor)

SHADOW_NORMAL_OFFSET = 0.5  # texel widths at the receiver (lighting.glsl's shadow_bias; tests/test_shadows.py)
MAX_LIGHTS = 8  # shadow maps take texture units 8..15, caustic maps 16..23 (NVIDIA and llvmpipe have 32)
CUBE_FORWARD = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=np.float64)
CUBE_UP = np.array([[0, 1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1], [0, 1, 0], [0, 1, 0]], dtype=np.float64)


@dataclass
class LightSample:
    """One shadowed emitter as the shaders see it (a line light gives several)."""

    type: int
    position: np.ndarray
    direction: np.ndarray
    intensity: np.ndarray
    cone_cos: tuple[float, float] = (1.0, 1.0)
    clip_from_world: np.ndarray | None = None  # directional and spot maps
    environment: bool = False  # the environment's sun (passes/environment_lights.py), not one of scene.lights


def light_samples(scene) -> list[LightSample]:
    """Expand the scene's lights into point/directional/spot samples, then the environment's sun as a
    directional sample (passes/environment_lights.py) where it has one and a sample is free."""
    center = scene.bounds().mean(axis=0)
    radius = 0.5 * np.linalg.norm(np.ptp(scene.bounds(), axis=0)) + 1e-6
    samples: list[LightSample] = []
    for light in scene.lights:
        if isinstance(light, DirectionalLight):
            samples.append(_directional_sample(light, center, radius))
        elif isinstance(light, SpotLight):
            view = look_at_view_from_world(light.position, light.position + light.direction, up_hint(light.direction))
            far = np.linalg.norm(light.position - center) + 2 * radius
            clip = perspective_clip_from_view(2 * light.outer_angle + 2.0, 1.0, 0.01 * radius, far) @ view
            cones = (float(np.cos(np.radians(light.inner_angle))), float(np.cos(np.radians(light.outer_angle))))
            samples.append(LightSample(LIGHT_SPOT, light.position, light.direction, light.intensity, cones, clip))
        else:
            for position, intensity in light.point_samples():
                samples.append(LightSample(LIGHT_POINT, position, np.array([0.0, -1.0, 0.0]), intensity))
    if len(samples) > MAX_LIGHTS:
        raise TechniqueError(
            f"the scene has {len(samples)} light samples but at most {MAX_LIGHTS} are supported; "
            "use fewer lights or fewer line-light samples"
        )
    sun = environment_sun(scene.environment).light
    if sun is not None and len(samples) < MAX_LIGHTS:
        samples.append(dataclasses.replace(_directional_sample(sun, center, radius), environment=True))
    return samples


def _directional_sample(light: DirectionalLight, center: np.ndarray, radius: float) -> LightSample:
    """A directional light's sample: an orthographic map over the sphere (center, radius) around the scene."""
    origin = center - light.direction * 2.0 * radius
    view = look_at_view_from_world(origin, center, up_hint(light.direction))
    clip = orthographic_clip_from_view(radius, radius, 0.01 * radius, 4.0 * radius) @ view
    return LightSample(LIGHT_DIRECTIONAL, origin, light.direction, light.intensity, clip_from_world=clip)


def draw_objects(frame: Frame, program, objects, clip_from_world: np.ndarray) -> None:
    """Draw objects with the shared mesh vertex stage."""
    set_uniform(program, "clip_from_world", clip_from_world)
    for obj in objects:
        set_object_transform(program, obj.world_from_object())
        frame.gpu.meshes.get(obj.mesh).render(program)


class ShadowMaps(Pass):
    """Distance-to-light maps for every light sample (reused while lights and objects stay put), and, where
    the frame's parameters ask for ``environment_lobes`` (auto sets it), the environment's lobes' directional
    maps side by side in one atlas (passes/environment_lights.py)."""

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
        tiles = [_directional_sample(DirectionalLight(d, np.ones(3)), center, radius) for d in lobes.directions]
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
        program = frame.gpu.shaders.compute("passes/lobe_nearest.comp")
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
        from .surfaces import FIRST_SHADOW_UNIT

        ctx = frame.gpu.ctx
        target = frame.own(ctx.texture((size * len(tiles), size), 4, dtype="f4"))
        fbo = frame.own(ctx.framebuffer([target], frame.own(ctx.depth_renderbuffer((size * len(tiles), size)))))
        program = frame.gpu.shaders.program("common/mesh_vertex.glsl", "passes/lobe_bounce.frag",
                                            {"MAX_LIGHTS": MAX_LIGHTS})
        bind_lights(program, samples, maps, first_unit=FIRST_SHADOW_UNIT)
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
                program = frame.gpu.shaders.program("common/mesh_vertex.glsl", "passes/glass_optical_depth.frag",
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
        program = gpu.shaders.program("common/mesh_vertex.glsl", "passes/distance.frag", {"ALONG_DIRECTION": along})
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


def bind_lights(program, samples: list[LightSample], maps: list, first_unit: int,
                shadow_bias: float = SHADOW_NORMAL_OFFSET) -> None:
    """Set the lighting.glsl uniforms and bind shadow maps from texture unit ``first_unit``; ``shadow_bias``
    is the receiver's normal offset in texel widths of its map."""
    count = len(samples)
    set_uniform(program, "light_count", count)
    set_uniform(program, "shadow_bias", shadow_bias)  # the environment lobes' maps take it too
    if count == 0:
        return

    def pad(rows, width):
        out = np.zeros((MAX_LIGHTS, width), dtype="f4")
        out[:count] = rows
        return out

    set_uniform(program, "light_type", np.array([s.type for s in samples] + [0] * (MAX_LIGHTS - count), dtype="i4"))
    set_uniform(program, "light_position", pad([s.position for s in samples], 3))
    set_uniform(program, "light_direction", pad([s.direction for s in samples], 3))
    set_uniform(program, "light_intensity", pad([s.intensity for s in samples], 3))
    set_uniform(program, "light_cone_cos", pad([s.cone_cos for s in samples], 2))
    clips = np.zeros((MAX_LIGHTS, 4, 4), dtype="f4")
    for i, s in enumerate(samples):
        clips[i] = s.clip_from_world if s.clip_from_world is not None else np.eye(4)
    if "light_clip_from_world" in program:
        program["light_clip_from_world"].write(np.ascontiguousarray(clips.transpose(0, 2, 1)).tobytes())
    set_uniform(program, "cube_forward", CUBE_FORWARD.astype("f4"))
    set_uniform(program, "cube_up", CUBE_UP.astype("f4"))
    units = []
    for i in range(MAX_LIGHTS):
        unit = first_unit + min(i, count - 1)
        units.append(unit)
    for i, tex in enumerate(maps):
        tex.use(first_unit + i)
    if "shadow_map" in program:
        program["shadow_map"].write(np.array(units, dtype="i4").tobytes())


