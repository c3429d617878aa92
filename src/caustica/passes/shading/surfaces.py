"""Camera-view passes shared by techniques: refractor surface buffers, surface shading, the environment behind."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, Callable

import moderngl
import numpy as np

from ...gpu.meshes import bind_samplers, set_uniform
from ...lighting.environment import ambient_sh
from ...lighting.samples import MAX_LIGHTS
from ...render.bindings import (MATERIAL_MAPS, MAX_CAUSTIC_TILES, MAX_INPUTS, bind_baked_object, bind_caustic_maps,
                                bind_caustic_tiles, bind_environment_bake, bind_environment_shadows, bind_lights,
                                bind_material_maps, bind_receiver_tiles, bind_reflection_probe, bind_split_sum,
                                first_unit)
from ...render.draw import attach_tangents, culled_back_faces, culls_back_faces, draw_objects, draw_refractor_buffer
from ...render.frame import Channel, Frame, Pass
from ...scene.codes import MATERIAL_CODES
from ...scene.materials import Principled
from ...scene.textures import texture_of
from ..post.adaptive import FLAGS, preset_depth
from . import deferred
from .deferred import DEFER_GBUFFER, DEFER_SHADE_NOW
from .prefiltered import PREFILTER_LEVELS, brdf_table_texture, prefiltered_environment, reflected_environment

BAKED_VERTEX_STAGES = ("common/mesh_vertex.glsl", "passes/shading/transport_view.vert")  # they pass baked_vertex_irradiance


class RefractorSurfaces(Pass):
    """Front or back faces of the refractors: outward world normal and eye distance per pixel.

    ``face`` 'back' with ``order`` 'farthest' is Wyman's back-face buffer (the far side
    of a convex refractor); 'nearest' keeps the second surface of a nonconvex one
    (a one-layer depth peel). ``face`` 'front' gives the nearest front faces (Hu and Qin).
    """

    reads = ()

    def __init__(self, face: str = "back", order: str = "farthest", absorbing_only: bool = False):
        """``absorbing_only``: the buffer only serves Beer-Lambert thickness (env-map), so it stays
        empty (cleared, nothing drawn) when no glass in the scene absorbs."""
        if face not in ("front", "back") or order not in ("nearest", "farthest"):
            raise ValueError("face must be 'front' or 'back', order 'nearest' or 'farthest'")
        self.face, self.order, self.absorbing_only = face, order, absorbing_only
        self.writes = (refractor_channel(face, order),)
        self.channel = self.writes[0].name

    def run(self, frame: Frame) -> None:
        objects = frame.scene.objects_of("glass")
        if self.absorbing_only:
            objects = [o for o in objects if np.any(o.material.absorption_coefficient > 0)]
        frame.write(self.channel, refractor_surfaces(frame, self.face, self.order, objects))


def refractor_channel(face: str, order: str) -> Channel:
    """The channel a refractor buffer is written to (RefractorSurfaces, ShadeSurfaces' captured front faces)."""
    return Channel(f"{face}_surface", "rgba32f",
                   f"{order} {face}-facing refractor surface: outward world normal xyz, eye distance w (0: none)")


def refractor_surfaces(frame: Frame, face: str, order: str, objects) -> object:
    """RefractorSurfaces' buffer of ``objects``: outward world normal and eye distance per pixel."""
    program = frame.gpu.shaders.program("common/mesh_vertex.glsl", "passes/shading/surface_normal_distance.frag")
    set_uniform(program, "origin", frame.camera.position.astype("f4"))
    return draw_refractor_buffer(frame, program, "rgba32f", face, order, objects)


@dataclass
class ShadeOptions:
    """ShadeSurfaces' options, in the order of its positional arguments."""

    fragment: str = "passes/shading/env_map.frag"  # the surface fragment shader (default: the env-map baseline)
    defines: dict | None = None  # its defines
    material_override: Any = None  # one material for every object (None: each its own)
    inputs: tuple[str, ...] = ("back_surface",)  # channels bound as samplers of the same name
    set_uniforms: Callable | None = None  # set_uniforms(program, frame, obj): own uniforms (obj None: per frame)
    objects: Any = None  # object names or a predicate f(obj) -> bool: the objects drawn (None: all)
    background: bool = True  # True: this run starts the targets (cleared); False: draws over an earlier run's (per-object)
    tag: str = ""  # names the run in pass timings
    vertex: str = "common/mesh_vertex.glsl"  # the vertex stage (writes world_position, world_normal as this one)
    frame_defines: Callable | None = None  # frame_defines(frame) -> dict: defines from the frame's channels
    deferred: tuple[str, ...] = ()  # material kinds shaded once per visible pixel from a G-buffer (passes/shading/deferred.py)
    captures_front_surface: bool = False  # writes the front_surface input itself, from the glass G-buffer if it can
    staged: tuple[str, ...] = ()  # deferred kinds resolved in two stages (passes/shading/deferred.py)

    def __post_init__(self):
        if len(self.inputs) > MAX_INPUTS:
            raise ValueError(f"ShadeSurfaces binds at most {MAX_INPUTS} input channels")
        self.defines = self.defines or {}
        self.inputs = tuple(self.inputs)
        self.objects = self.objects if self.objects is None or callable(self.objects) else frozenset(self.objects)
        self.background = bool(self.background)
        self.deferred, self.staged = tuple(self.deferred), tuple(self.staged)
        if self.deferred and (self.vertex != "common/mesh_vertex.glsl" or len(self.inputs) + 1 > MAX_INPUTS):
            raise ValueError("deferred shading needs the shared vertex stage and a free input unit")
        if self.staged and len(self.inputs) + 2 > MAX_INPUTS:  # the G-buffer, then the second stage's flags
            raise ValueError("a two-stage resolve needs two free input units")
        self.captures_front_surface = bool(self.captures_front_surface)
        if self.captures_front_surface and ("front_surface" not in self.inputs or "glass" not in self.deferred):
            raise ValueError("captures_front_surface needs 'front_surface' among the inputs and glass deferred")


class ShadeSurfaces(Pass):
    """Every object shaded by a surface fragment shader, into targets this run clears (``background``) or an
    earlier run's; ShadeBackground then fills the pixels no object covers.

    The default shader is the env-map baseline; techniques pass their own
    fragment shader and extra uniforms for refractors. Each ShadeOptions field is an attribute too.
    """

    writes = (
        Channel("color", "rgba32f", "linear radiance seen by the camera"),
        Channel("exit_direction", "rgba32f", "world direction of the light path leaving a refractor; w = 1 where defined"),
        Channel("depth", "depth", "camera depth buffer"),
    )

    # Caustic irradiance added to diffuse receivers when a caustic technique wrote it (passes/caustics/maps.py);
    # adaptive anti-aliasing's flags (passes/post/adaptive.py), given by the renderer: only flagged pixels shade.
    optional = {"caustic_maps": "CAUSTICS", "caustic_tiles": "CAUSTIC_TILES",
                "environment_shadows": "ENVIRONMENT_SHADOWS", "environment_bake": "ENVIRONMENT_BAKE",
                "reflection_probes": None, FLAGS.name: None}

    def __init__(self, *args, options: ShadeOptions | None = None, **overrides):
        """``args``, ``overrides``: ShadeOptions fields (in order, by name), over ``options`` when given.

        ``captures_front_surface`` fills RefractorSurfaces' nearest front faces from the glass draw of
        the G-buffer when glass is deferred and drawn first and every refractor is a culled solid this
        run draws (one draw of each refractor fewer), else by drawing that buffer first."""
        if options is not None and args:
            raise TypeError("ShadeSurfaces takes options or positional fields, not both")
        self.options = (ShadeOptions(*args, **overrides) if options is None
                        else dataclasses.replace(options, **overrides))
        targets = () if self.background else tuple(c.name for c in ShadeSurfaces.writes)
        own = ("front_surface",) if self.captures_front_surface else ()
        self.reads = ("light_samples", "shadow_maps") + tuple(i for i in self.inputs if i not in own) + targets
        if own:
            self.writes = ShadeSurfaces.writes + (refractor_channel("front", "nearest"),)

    @property
    def label(self) -> str:
        return f"ShadeSurfaces({self.tag})" if self.tag else "ShadeSurfaces"

    @property
    def deferred_unit(self) -> int:
        """The texture unit of the G-buffer (and the next, of the second stage's flags): after the inputs."""
        return first_unit("inputs") + len(self.inputs)

    def draws(self, obj) -> bool:
        """Whether this run shades ``obj``."""
        if self.objects is None:
            return True
        return self.objects(obj) if callable(self.objects) else obj.name in self.objects

    def run(self, frame: Frame) -> None:
        gpu, camera, scene = frame.gpu, frame.camera, frame.scene
        if self.background:
            color = frame.texture(camera.size, "rgba32f")
            exit_direction = frame.texture(camera.size, "rgba32f")
            depth = frame.texture(camera.size, "depth")
        else:  # draw over an earlier run's image
            color, exit_direction, depth = (frame.read(c.name) for c in self.writes)
        drawn = [(obj, self.material_of(obj)) for obj in scene.objects if self.draws(obj)]
        deferring = deferred.defers(drawn, self.deferred)
        front = None  # the front-surface buffer the glass G-buffer draw fills (captures_front_surface)
        if self.captures_front_surface:
            glass = scene.objects_of("glass")
            clip_from_world = camera.clip_from_world()
            # Not under adaptive flags: the G-buffer holds the flagged pixels alone, and the glass searches
            # this buffer at other pixels (depth-search's binary search).
            if (deferring and self.material_override is None and all(self.draws(o) for o in glass)
                    and all(culls_back_faces(o, clip_from_world) for o in glass)
                    and frame.optional(FLAGS.name) is None):
                front = frame.zeroed(camera.size, "rgba32f")
                frame.write("front_surface", front)
            else:
                frame.write("front_surface", refractor_surfaces(frame, "front", "nearest", glass))
        if deferring:
            # Cleared before anything is drawn: on llvmpipe (Mesa 22.3.6) clearing it right after a
            # draw into the colour target lost part of that draw (test_deferred_* guards this).
            g_buffer = frame.zeroed(camera.size, "rgba32f")  # normal times id, distance along the ray
        fbo = gpu.targets.framebuffer([color, exit_direction], depth)
        fbo.use()
        if self.background:
            fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            if frame.optional(FLAGS.name) is not None:  # before the environment takes unit 0
                preset_depth(frame, depth, frame.optional(FLAGS.name))
                fbo.use()
        if any(dict(principled_defines(obj, material)).get("GLOSSY") for obj, material in drawn):
            # Before the targets are bound: a pass of its own.
            prefiltered_environment(gpu, reflected_environment(scene.environment, frame.read("light_samples")))
            fbo.use()
        environment = gpu.environment_texture(scene.environment)
        environment.use(0)
        if deferring:
            targets = deferred.gbuffer_targets(gpu, color, exit_direction, g_buffer, depth, front)
            later = self._draw_objects(frame, drawn, targets)
            if later:
                deferred.resolve(frame, self, later, color, exit_direction, g_buffer)
        else:
            self._draw_objects(frame, drawn)
        frame.write("color", color)
        frame.write("exit_direction", exit_direction)
        frame.write("depth", depth)

    def _draw_objects(self, frame: Frame, drawn: list, deferring_targets: dict | None = None) -> list:
        """This run's objects (``drawn``: (object, material) pairs), depth tested against what earlier
        runs drew (ShadeBackground comes after).

        Deferring, each DEFERRED_SHADING mode draws into its framebuffer of ``deferring_targets``
        (deferred.gbuffer_targets);
        returns the deferred (object, material, defines), in G-buffer id order."""
        gpu, ctx, camera = frame.gpu, frame.gpu.ctx, frame.camera
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        caustic_maps = frame.optional("caustic_maps")
        defines = {**self.defines, "MAX_LIGHTS": MAX_LIGHTS, **frame.optional_defines(self),
                   "MAX_CAUSTIC_TILES": MAX_CAUSTIC_TILES}
        if frame.optional("environment_shadows") is not None:
            defines.update(frame.optional("environment_shadows").defines())
        bake = frame.optional("environment_bake")
        # Receivers baked per vertex read them from the vertex stage (common/baked_vertex.glsl).
        baked_vertices = bake is not None and bake.has_vertices and self.vertex in BAKED_VERTEX_STAGES
        if self.frame_defines is not None:
            defines.update(self.frame_defines(frame))
        clip_from_world = camera.clip_from_world()
        # Front to back, so that a CPU rasterizer's early depth test skips hidden fragments.
        drawn.sort(key=lambda item: _distance_to_bounds(camera.position, item[0].world_mesh().bounds))
        # One program variant per material kind, dispersion, texture and PBR features (SURFACE_KIND,
        # DISPERSION, ALBEDO_TEXTURE, principled_defines): CPU rasterizers pay for every side of a branch,
        # even one on a uniform.
        variants = sorted({self.variant_of(obj, material) for obj, material in drawn})
        capturing = bool(deferring_targets) and "glass" in deferring_targets
        if capturing:  # glass first: the front-surface buffer must hold the refractors alone
            variants.sort(key=lambda variant: variant[0] != "glass")
        later = []  # the deferred (object, material, variant defines) in G-buffer id order
        for variant in variants:
            kind, dispersion, textured, features = variant
            variant_defines = {**defines, "SURFACE_KIND": MATERIAL_CODES[kind], "DISPERSION": int(dispersion),
                               **({"ALBEDO_TEXTURE": 1} if textured else {}), **dict(features),
                               **({"ENVIRONMENT_BAKE_VERTICES": 1} if baked_vertices and kind == "diffuse" else {}),
                               **probe_defines(frame, features)}
            program_defines = variant_defines
            # The G-buffer holds no uvs, and no face orientation (a normal map's frame).
            defer = kind in self.deferred and not textured and "SURFACE_UV" not in variant_defines
            if deferring_targets:
                mode = DEFER_GBUFFER if defer else DEFER_SHADE_NOW
                variant_defines["DEFERRED_SHADING"] = mode
                if capturing and kind == "glass":
                    program_defines = {**variant_defines, "CAPTURE_FRONT_SURFACE": 1}
                    deferring_targets["glass"].use()
                else:
                    deferring_targets[mode].use()
            program = gpu.shaders.program(self.vertex, self.fragment, program_defines)
            self.set_frame_uniforms(frame, program, caustic_maps)
            if deferring_targets:
                deferred.set_ray_uniforms(program, camera)
            for obj, material in drawn:
                if self.variant_of(obj, material) != variant:
                    continue
                if "NORMAL_TEXTURE" in variant_defines:
                    attach_tangents(gpu, obj.mesh)
                if deferring_targets and defer:
                    later.append((obj, material, variant_defines))
                    set_uniform(program, "deferred_id", float(len(later)))
                else:
                    self.set_object_uniforms(frame, program, obj, material)
                with culled_back_faces(ctx, obj, clip_from_world):
                    draw_objects(frame, program, [obj], clip_from_world)
        return later

    def set_object_uniforms(self, frame: Frame, program, obj, material) -> None:
        """What one object's shading needs: its material, caustic tiles, the technique's uniforms."""
        set_uniform(program, "material_kind", MATERIAL_CODES[material.kind])
        set_uniform(program, "material_color", _material_color(material))
        if material.kind == "glass":
            set_uniform(program, "ior_rgb", material.ior_rgb.astype("f4"))
            set_uniform(program, "absorption_coefficient", material.absorption_coefficient.astype("f4"))
        texture = self.albedo_texture(obj, material)
        if texture is not None:
            frame.gpu.albedo_texture(texture).use(first_unit("albedo"))
            set_uniform(program, "albedo_texture", first_unit("albedo"))
        features = dict(principled_defines(obj, material))
        if features:
            set_principled_uniforms(program, frame, material, features)
            if probe_defines(frame, features):
                bind_object_probe(program, frame, obj)
        tiles = frame.optional("caustic_tiles")
        if tiles is not None and material.kind == "diffuse":
            bind_receiver_tiles(program, tiles, obj)
        bake = frame.optional("environment_bake")
        if bake is not None:
            bind_baked_object(program, bake, frame.scene, obj)
        if self.set_uniforms is not None:
            self.set_uniforms(program, frame, obj)

    def material_of(self, obj):
        """The material ``obj`` is drawn with: ``material_override`` where one is given, but under an
        untextured diffuse override (plain's grey) an opaque PBR receiver keeps its own: its lobe and maps
        belong to the surface, as a texture does (albedo_texture)."""
        override = self.material_override
        if override is None:
            return obj.material
        if override.kind == "diffuse" and override.texture is None and principled_defines(obj, obj.material):
            return obj.material
        return override

    def albedo_texture(self, obj, material):
        """The texture ``obj`` shows drawn with ``material`` (scene/textures.py texture_of); under an
        untextured diffuse ``material_override`` (plain's grey), the object's own: the texture belongs
        to the surface, the override replaces its colour."""
        if material is self.material_override and material.kind == "diffuse" and material.texture is None:
            return texture_of(obj)
        return texture_of(obj, material)

    def variant_of(self, obj, material) -> tuple[str, bool, bool, tuple]:
        """(kind, dispersive, textured, principled_defines): which compiled shader variant shades ``obj`` drawn
        with ``material``."""
        return (*_variant(material), self.albedo_texture(obj, material) is not None, principled_defines(obj, material))

    def set_frame_uniforms(self, frame: Frame, program, caustic_maps) -> None:
        """What every object of the frame shares: environment, inputs, camera, lights, caustics."""
        camera, scene = frame.camera, frame.scene
        set_uniform(program, "environment", 0)
        set_uniform(program, "environment_pixel_angle", camera.pixel_angle())
        bind_samplers(program, self.inputs, [frame.read(name) for name in self.inputs], first_unit("inputs"))
        set_uniform(program, "camera_position", camera.position.astype("f4"))
        set_uniform(program, "camera_clip_from_world", camera.clip_from_world())
        set_uniform(program, "intensity_scale", float(scene.intensity_scale))
        samples = frame.read("light_samples")
        shadows = frame.optional("environment_shadows")
        bake = frame.optional("environment_bake")
        set_uniform(program, "irradiance_sh", ambient_sh(scene.environment, samples, shadows, bake).astype("f4"))
        bind_lights(program, samples, frame.read("shadow_maps"))
        if shadows is not None:
            bind_environment_shadows(program, shadows)
        if bake is not None:
            bind_environment_bake(program, bake)
        if "prefiltered_environment" in program:  # a glossy variant (run() prefiltered its environment)
            reflected = reflected_environment(scene.environment, samples)
            bind_split_sum(program, brdf_table_texture(frame.gpu), prefiltered_environment(frame.gpu, reflected),
                           PREFILTER_LEVELS)
        if caustic_maps is not None:
            bind_caustic_maps(program, caustic_maps)
        elif frame.optional("caustic_tiles") is not None:
            bind_caustic_tiles(program, frame.optional("caustic_tiles"))
        if self.set_uniforms is not None:
            self.set_uniforms(program, frame, None)


class ShadeBackground(Pass):
    """The environment through every pixel no object covers: a triangle on the far plane, depth tested (not
    written) after the objects, so that the early depth test skips covered pixels."""

    reads = ("color", "exit_direction", "depth")
    writes = ShadeSurfaces.writes

    def run(self, frame: Frame) -> None:
        gpu, ctx, camera, scene = frame.gpu, frame.gpu.ctx, frame.camera, frame.scene
        color, exit_direction, depth = (frame.read(name) for name in self.reads)
        gpu.targets.framebuffer([color, exit_direction], depth).use()
        gpu.environment_texture(scene.environment).use(0)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<="
        ctx.fbo.depth_mask = False
        background = gpu.shaders.program("common/fullscreen.vert", "passes/shading/background.frag")
        set_uniform(background, "environment", 0)
        set_uniform(background, "world_from_clip", np.linalg.inv(camera.clip_from_world()))
        set_uniform(background, "intensity_scale", float(scene.intensity_scale))
        set_uniform(background, "environment_pixel_angle", camera.pixel_angle())
        gpu.draw_fullscreen(background)
        ctx.fbo.depth_mask = True
        ctx.depth_func = "<"
        for name, value in zip(self.reads, (color, exit_direction, depth)):
            frame.write(name, value)


def _distance_to_bounds(point, bounds: np.ndarray) -> float:
    """Distance from ``point`` to the box ``bounds`` (2, 3); 0 inside it."""
    point = np.asarray(point, np.float64)
    return float(np.linalg.norm(point - np.clip(point, bounds[0], bounds[1])))


def _variant(material) -> tuple[str, bool]:
    """(kind, dispersive): which compiled shader variant shades a material (its texture aside)."""
    dispersive = material.kind == "glass" and bool(np.ptp(material.ior_rgb) > 0)
    return material.kind, dispersive


def principled_defines(obj, material) -> tuple[tuple[str, int], ...]:
    """The defines of an opaque PBR receiver's variant (common/surface_inputs.glsl), sorted: GLOSSY for its
    specular lobe, each map's where the mesh has uvs (with SURFACE_UV), EMISSIVE for emission; () for any other
    surface, a Principled without lobe, maps or emission included (it is drawn as its Diffuse)."""
    if material.kind != "diffuse" or not isinstance(material, Principled):
        return ()
    emissive = bool(np.any(material.emission > 0))
    maps = [name for name in MATERIAL_MAPS if obj.mesh.uvs is not None and getattr(material, name) is not None
            and (emissive or name != "emission_texture")]
    defines = {name.upper(): 1 for name in maps}
    defines.update({"SURFACE_UV": 1} if maps else {})
    defines.update({"GLOSSY": 1} if material.glossy else {})
    defines.update({"EMISSIVE": 1} if emissive else {})
    return tuple(sorted(defines.items()))


def probe_defines(frame: Frame, features) -> dict:
    """REFLECTION_PROBE (and PROBE_PARALLAX) for a glossy variant (``features``: its principled_defines) when the
    frame has reflection probes (passes/shading/reflection_probes.py), else nothing."""
    probes = frame.optional("reflection_probes")
    if not dict(features).get("GLOSSY") or probes is None:
        return {}
    return {"REFLECTION_PROBE": 1, **({"PROBE_PARALLAX": 1} if probes.parallax else {})}


def bind_object_probe(program, frame: Frame, obj) -> None:
    """Bind the reflection probe ``obj`` reads; one without a probe (a planar receiver, reflection_probes.py
    takes_probe) reads the prefiltered environment, through a proxy box too far to correct anything."""
    probe = frame.optional("reflection_probes").probe_for(frame.scene, obj)
    if probe is None:
        reflected = reflected_environment(frame.scene.environment, frame.read("light_samples"))
        far = np.full(3, 1e30)
        probe = SimpleNamespace(atlas=prefiltered_environment(frame.gpu, reflected), centre=np.zeros(3),
                                box=np.stack([-far, far]))
    bind_reflection_probe(program, probe)


def set_principled_uniforms(program, frame: Frame, material, features: dict) -> None:
    """An opaque PBR receiver's factors and maps (``features``: its principled_defines)."""
    set_uniform(program, "material_metallic", float(material.metallic))
    set_uniform(program, "material_roughness", float(material.roughness))
    set_uniform(program, "material_dielectric_f0", material.dielectric_f0.astype("f4"))
    set_uniform(program, "material_emission", np.asarray(material.emission, "f4"))
    set_uniform(program, "material_normal_scale", float(material.normal_scale))
    set_uniform(program, "material_occlusion_strength", float(material.occlusion_strength))
    bind_material_maps(program, frame.gpu, material, [name for name in MATERIAL_MAPS if name.upper() in features])


def _material_color(material) -> np.ndarray:
    return np.asarray(getattr(material, "color", np.ones(3)), dtype="f4")


def _option(name: str) -> property:
    """ShadeSurfaces' attribute ``name``: its ShadeOptions field, read and written (techniques set some later)."""
    return property(lambda shade: getattr(shade.options, name),
                    lambda shade, value: setattr(shade.options, name, value), doc=f"ShadeOptions.{name}")


for _field in dataclasses.fields(ShadeOptions):
    setattr(ShadeSurfaces, _field.name, _option(_field.name))
del _field
