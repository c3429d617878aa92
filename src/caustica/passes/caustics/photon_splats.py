"""Passes of Wyman's image-space caustics (``photon-splats``): the photon buffer rendered from the light.

Wyman, "Approximate, Image-Space Caustics", "Rendering From the Light": the
scene is rendered from the light with the image-space refraction routine, and
each refractor texel stores, instead of a colour, the photon that leaves it.

- :class:`RefractFromLight` draws the scene in the photon buffer's light view
  (``caster_views``, fitted around the refractors) with
  ``shaders/passes/caustics/photon_refract.frag``: exit point P2, exit direction T2 and
  flux per texel (one photon per RGB channel when a glass disperses). d_N comes
  from :func:`caustica.passes.shading.image_space.distance_along_normal` (per vertex,
  cached), d_V and N2 from the refractors' back faces seen from the light
  (``caster_back``, :class:`caustica.passes.caustics.light_space.LightSurfaces`).
- :class:`LandPhotons` lands the photons on the receivers
  (``shaders/passes/caustics/photon_land.comp``): the intersection estimate against the
  receivers' light-space position texture, into a
  :class:`caustica.passes.caustics.light_space.Photons` buffer, the format
  :class:`~caustica.passes.caustics.light_space.SplatPhotons` reads.
"""
from __future__ import annotations

import moderngl
import numpy as np

from ...gpu.meshes import bind_samplers, set_object_transform, set_uniform
from ...render.frame import Channel, Frame, Pass
from ..shading.glass_contact import bind_contact_plane, contact_defines
from ..shading.image_space import DN_ATTRIBUTE, distance_along_normal
from .casters import CASTER_NONE, CASTER_SOLID, MAX_CASTERS, caster_code, casters, half_diagonal, length_unit
from .light_space import dispatch_photons
from .light_views import LightView, bind_views

TIR_MODES = ("keep-t1", "clamp", "reflect", "drop")
ESTIMATOR_NEWTON = 1  # estimate_distance's Newton-Raphson with bisection fallback


def dispersive(scene) -> bool:
    """Whether some glass has different IORs per channel (then one photon per channel)."""
    return any(np.ptp(o.material.ior_rgb) > 0 for o in scene.objects_of("glass"))


class RefractFromLight(Pass):
    """The refractors rendered from the light with Wyman's refraction routine: one photon per texel.

    Writes, per light, a tuple of pooled rgba32f textures in the photon
    buffer's view: flux (W; alpha = caster index + 1 where a single surface
    leaves the absorption to the landing pass), then exit point and exit
    direction for each of the ``channels`` photons of a texel.
    """

    reads = ("light_samples", "caster_views", "caster_back")
    writes = (Channel("photon_exits", "rgba32f x3[light]", "per light: (flux, exit point, direction[, ...]) textures "
                                                                "(x7 when dispersive), or None"),)

    def __init__(self, tir_mode: str = "clamp", use_dn: bool = True):
        self.tir_mode, self.use_dn = tir_mode, bool(use_dn)

    def run(self, frame: Frame) -> None:
        out = []
        for view, back in zip(frame.read("caster_views"), frame.read("caster_back")):
            out.append(None if view is None else self.render(frame, view, back))
        frame.write("photon_exits", out)

    def render(self, frame: Frame, view: LightView, back):
        channels = 3 if dispersive(frame.scene) else 1
        targets = [frame.texture(view.atlas_size, "rgba32f") for _ in range(1 + 2 * channels)]
        with frame.scratch(view.atlas_size, "depth") as depth:
            self._draw_all(frame, view, back, channels, frame.gpu.targets.framebuffer(targets, depth))
        return tuple(targets)

    def _draw_all(self, frame: Frame, view: LightView, back, channels: int, fbo) -> None:
        """The photon buffer's draw into ``fbo``: every object, the casters making photons."""
        gpu, ctx, scene = frame.gpu, frame.gpu.ctx, frame.scene
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        defines = {"CHANNELS": channels, "USE_DN": int(self.use_dn), "TIR_MODE": TIR_MODES.index(self.tir_mode),
                   **contact_defines(frame)}
        program = gpu.shaders.program("passes/shading/image_space.vert", "passes/caustics/photon_refract.frag", defines)
        view.bind(program)
        set_uniform(program, "length_unit", length_unit(scene))
        bind_samplers(program, ("back_position", "back_normal"), back)
        # Nearest surface per texel: refractors and mirrors make photons, everything else occludes.
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)  # open meshes (water) are seen from either side
        ctx.depth_func = "<"
        makers = casters(scene)
        for face in range(view.faces):
            fbo.viewport = (face * view.size, 0, view.size, view.size)
            set_uniform(program, "clip_from_world", view.clips[face])
            for obj in scene.objects:
                self._draw(frame, program, obj, makers, defines["GLASS_CONTACT"])

    def _draw(self, frame: Frame, program, obj, makers: list, contact: int) -> None:
        kind = caster_code(obj) if obj in makers else CASTER_NONE
        gpu_mesh = frame.gpu.meshes.get(obj.mesh)
        if kind == CASTER_SOLID and self.use_dn and DN_ATTRIBUTE not in gpu_mesh.attributes:
            gpu_mesh.set_attribute(DN_ATTRIBUTE, distance_along_normal(obj.mesh))
        material = obj.material
        set_uniform(program, "object_kind", kind)
        set_uniform(program, "object_index", makers.index(obj) if obj in makers else -1)
        if material.kind == "glass":
            set_uniform(program, "object_ior", np.asarray(material.ior_rgb, "f4"))
            set_uniform(program, "object_sigma", np.asarray(material.absorption_coefficient, "f4"))
        if material.kind == "mirror":
            set_uniform(program, "object_color", np.asarray(material.color, "f4"))
        if contact:
            bind_contact_plane(program, frame.scene, obj)
        set_object_transform(program, obj.world_from_object())
        gpu_mesh.render(program)


class LandPhotons(Pass):
    """The photons of ``photon_exits`` landed on the receivers of a light view: the photon buffer.

    ``iterations`` Newton-Raphson steps of the intersection estimate (bisection
    fallback) from the receiver behind the exit point, or from where the
    ``initial`` photons (an earlier pass, same layout) landed.
    """

    def __init__(self, receivers: str, receiver_views: str, channel: str, iterations: int, initial: str | None = None):
        self.receivers, self.receiver_views, self.channel = receivers, receiver_views, channel
        self.iterations, self.initial = int(iterations), initial
        self.reads = ("photon_exits", receivers, receiver_views) + ((initial,) if initial else ())
        self.writes = (Channel(channel, "buffer[light]", "per light: Photons (landing point, flux) or None"),)

    def run(self, frame: Frame) -> None:
        scene = frame.scene
        sigmas = np.zeros((MAX_CASTERS, 3), "f4")
        for i, obj in enumerate(casters(scene)):
            if obj.material.kind == "glass":
                sigmas[i] = obj.material.absorption_coefficient
        exits_per_light = frame.read("photon_exits")
        initials = frame.read(self.initial) if self.initial else [None] * len(exits_per_light)
        out = []
        for exits, receivers, view, initial in zip(exits_per_light, frame.read(self.receivers),
                                                   frame.read(self.receiver_views), initials):
            if exits is None or receivers is None or view is None:
                out.append(None)
                continue
            channels = (len(exits) - 1) // 2
            program = frame.gpu.shaders.compute("passes/caustics/photon_land.comp", {"CHANNELS": channels, "MAX_CASTERS": MAX_CASTERS})
            set_uniform(program, "caster_sigma", sigmas)
            set_uniform(program, "iterations", self.iterations)
            set_uniform(program, "estimator", ESTIMATOR_NEWTON)
            set_uniform(program, "fallback_distance", half_diagonal(scene.objects))
            set_uniform(program, "length_unit", length_unit(scene))
            bind_views(program, [view])
            names = ["photon_flux"] + [f"photon_{kind}{c}" for c in range(channels) for kind in ("origin", "direction")]
            bind_samplers(program, names + ["receiver_position"], (*exits, receivers[0]))
            width, height = exits[0].size
            out.append(dispatch_photons(frame, program, (width, height), width * height * channels, initial,
                                        {"channels": channels}))
        frame.write(self.channel, out)
