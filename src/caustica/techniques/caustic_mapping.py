"""``caustic-mapping``: caustics by image-space photon tracing from the light (Shah et al.).

Shah, Konttinen and Pattanaik, "Caustics Mapping: An Image-space Technique for
Real-time Caustics" (TVCG 2007). Per light sample (``passes/light_space.py``,
``landing_chain``, which ``photon-splats`` shares):

1. Casters (glass and mirrors) from the light (III-B, second pass): nearest
   front faces of every object (positions + distance, normals + caster code;
   diffuse objects occlude the grid) and farthest back faces of the glass, in a
   view fitted tightly around the casters (``photon_grid`` texels a side; a
   point light whose casters do not fit one 120-degree frustum gets the cube
   atlas). One photon per covered texel (the paper's vertex grid).
2. Photon flux (III-E): the paper weights each vertex by (N.L)/V, V the
   occlusion-query pixel count, which spreads a fixed total over the visible
   grid. Our grid lives in light space, so each texel's flux is known exactly:
   intensity times the texel's solid angle (point, spot, with the cone falloff)
   or irradiance times its area perpendicular to the light (directional); N.L
   drops out, and V is the count of photons (``stats``). Then exact Fresnel
   transmittance at each interface, per channel.
3. Refraction (III-A, III-C): two interfaces for closed glass (Wyman's
   image-space method: P2 = P1 + d T1 with d = d_V, the front-to-back distance
   seen from the light, refined by ``exit_iterations`` steps of the same
   estimator against the back-face position texture; N2 from the back-face
   normal texture; total internal reflection at the exit drops the photon);
   one interface for open meshes (water surfaces: the photon continues to the
   receiver; a mesh with small holes, a scanned model, is closed:
   ``casters.caster_code``); a single specular bounce off Mirror objects (reflective caustics).
   Beer-Lambert e^(-sigma_a d) over the inside distance (or, for one surface,
   the distance to the receiver; III-E eq. 7). RGB dispersion: where a glass
   has ``ior_rgb`` that differ, three photons per texel, one per channel.
4. Intersection estimate (III-C/D) against the receivers' position texture:
   ``estimator='iterate'`` is the paper's approximation d <- |S(o + d r) - o|,
   ``iterations`` times (1 by default, as in the paper); ``'newton'`` is the
   appendix's Newton-Raphson with a finite-difference derivative, on the signed
   f(d) = light distance of o + d r minus the stored receiver distance, keeping
   a bracket and falling back to bisection when a step oscillates or leaves it.
   Unlike the paper's d0 = 1 (scene-unit dependent), the first guess is where
   the footprint pass (step 5) landed the photon, so ``iterations`` steps refine
   a converged guess against the fine receiver texture. The final position is
   a bilinear lookup of the receiver texture (sub-texel on smooth receivers).
5. Caustic map: the photons land first on a coarse receiver view over the
   whole scene (footprint pass: Newton-Raphson, light_space.COARSE_NEWTON_STEPS steps,
   first guess the receiver behind the origin); the caustic map's view is then fitted tightly around the
   landing points (III-F: frustum limitation; a point light whose footprint is
   wider than a frustum, or ``point_map='cube'``, gets the omnidirectional cube
   atlas), the receivers are rendered again in it and the photons retraced.
   Splat (III-F): compute shader with fixed-point atomics, or additive Gaussian
   point sprites (``splat``), each Gaussian sized by the photon's footprint (the
   area its grid cell lands on, from the grid neighbours' landing points: a ray
   differential; ``passes/light_space.py``, SplatPhotons) and at least
   ``splat_radius`` texels: a fixed kernel beat against the map's texels where the
   photons spread apart (moire rings, issue 19). Irradiance = flux / receiver area
   of the texel; alpha = receiver distance to the light.
   The maps are rebuilt only when lights, objects or materials change.

Approximate: the exit point through the back buffer (one layer: concave or
overlapping refractors exit wrongly; d_V + estimator steps), photons dropped at
exit TIR (no internal bounces), the intersection estimate (exact on planes in
a few steps; near receiver discontinuities, e.g. a mirror's reflection onto
another wall, it can land on the wrong surface, as the paper notes for
reflections), the first caster layer only (light through two glass objects in
a row, or glass then mirror, is not followed), one photon per grid texel
(the footprint splats blur the caustic to the photons' spacing where they
spread apart, and clamp a grazing photon's footprint, dropping the flux
beyond), Fresnel-reflected light
off glass is not splatted. Limits: receivers must be seen from the light
(the receiver texture holds one layer: a caustic on a surface hidden from the
light behind another diffuse object is lost); at most 32 casters.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..gpu.meshes import bind_samplers, set_uniform
from ..passes.base import Channel, Frame, Pass
from ..passes.casters import MAX_CASTERS, caster_code, casters, half_diagonal, length_unit
from ..passes.light_space import LightSurfaces, dispatch_photons, landing_chain
from ..passes.light_views import bind_views
from .composite import POINT_MAPS, SPLATS, CausticTechnique
from .base import param
from .env_map import ShadowedParams

ESTIMATORS = {"iterate": 0, "newton": 1}


@dataclass
class CausticMappingParams(ShadowedParams):
    """Parameters of ``caustic-mapping`` (Shah et al.)."""

    map_size: int = param(512, range=(16, 4096), unit="texels", paper="Shah et al. III-F",
                          help="caustic-map texels a side (per cube face)")
    photon_grid: int = param(0, range=(8, 4096), special={0: "= map_size"}, unit="photons", paper="Shah et al. III-B",
                             help="photons a side of the casters' grid")
    iterations: int = param(1, range=(0, 64), paper="Shah et al. III-D",
                            help="intersection-estimate steps (one suffices for caustics)")
    estimator: str = param("iterate", choices=tuple(ESTIMATORS), paper="Shah et al. III-C, appendix",
                           help="'iterate' (the paper's approximation) or 'newton' (the appendix; bisection fallback)")
    exit_iterations: int = param(6, range=(0, 64), paper="Wyman, eq. 6.3.1",
                                 help="regula falsi steps refining d_V against the back faces (0: d_V alone)")
    splat: str = param("auto", choices=SPLATS, help="'compute' (fixed-point atomics), 'points' (additive point sprites) or 'auto'")
    splat_radius: float = param(1.5, range=(0.75, 8.0), unit="texels", paper="Shah et al. III-F",
                                help="Gaussian splat radius in caustic-map texels (sigma = radius / 2)")
    point_map: str = param("frustum", choices=POINT_MAPS, paper="Shah et al. III-F",
                           help="point lights: 'frustum' (fitted, cube when too wide) or 'cube' (always)")

    def __post_init__(self):
        super().__post_init__()
        self.photon_grid = self.photon_grid or self.map_size


class TracePhotons(Pass):
    """One photon per caster texel: refract or reflect, estimate where it lands (Shah et al. III-C/D)."""

    def __init__(self, receivers: str, receiver_views: str, channel: str, params: CausticMappingParams,
                 initial: str | None = None, estimator: tuple[str, int] | None = None):
        """``initial``: photons of an earlier pass (same grid) whose landing points are the first guesses;
        ``estimator``: (name, iterations) instead of the parameters'."""
        self.receivers, self.receiver_views, self.channel, self.params = receivers, receiver_views, channel, params
        self.initial = initial
        self.estimator = estimator or (params.estimator, params.iterations)
        self.reads = ("light_samples", "caster_views", "caster_front", "caster_back", receivers, receiver_views)
        self.reads += (initial,) if initial else ()
        self.writes = (Channel(channel, "buffer[light]", "per light: Photons (landing point, flux) or None"),)

    def run(self, frame: Frame) -> None:
        scene, p = frame.scene, self.params
        types, iors, sigmas, colors = (np.zeros(MAX_CASTERS, "i4"), np.ones((MAX_CASTERS, 3), "f4"),
                                       np.zeros((MAX_CASTERS, 3), "f4"), np.zeros((MAX_CASTERS, 3), "f4"))
        dispersive = False
        for i, obj in enumerate(casters(scene)):
            material = obj.material
            types[i] = caster_code(obj)
            if material.kind == "mirror":
                colors[i] = material.color
            else:
                iors[i], sigmas[i] = material.ior_rgb, material.absorption_coefficient
                dispersive |= bool(np.ptp(material.ior_rgb) > 0)
        channels = 3 if dispersive else 1
        defines = {"VIEW_COUNT": 2, "MAX_CASTERS": MAX_CASTERS}
        program = frame.gpu.shaders.compute("passes/caustic_trace.comp", defines)
        set_uniform(program, "caster_type", types)
        set_uniform(program, "caster_ior", iors)
        set_uniform(program, "caster_sigma", sigmas)
        set_uniform(program, "caster_color", colors)
        set_uniform(program, "channel_count", channels)
        set_uniform(program, "iterations", self.estimator[1])
        set_uniform(program, "exit_iterations", p.exit_iterations)
        set_uniform(program, "estimator", ESTIMATORS[self.estimator[0]])
        set_uniform(program, "fallback_distance", half_diagonal(scene.objects))
        set_uniform(program, "length_unit", length_unit(scene))
        out = []
        initials = frame.read(self.initial) if self.initial else [None] * len(frame.read("caster_views"))
        for caster_view, front, back, receivers, receiver_view, initial in zip(
                frame.read("caster_views"), frame.read("caster_front"), frame.read("caster_back"),
                frame.read(self.receivers), frame.read(self.receiver_views), initials):
            if caster_view is None or receivers is None or receiver_view is None:
                out.append(None)
                continue
            width, height = caster_view.atlas_size
            bind_views(program, [caster_view, receiver_view])
            textures = (*front, *back, receivers[0]) if back is not None else (*front, *front, receivers[0])
            bind_samplers(program, ("front_position", "front_normal", "back_position", "back_normal",
                                    "receiver_position"), textures)
            out.append(dispatch_photons(frame, program, (width, height), width * height * channels, initial,
                                        {"channels": channels}))
        frame.write(self.channel, out)


class CausticMapping(CausticTechnique):
    name = "caustic-mapping"
    summary = "Caustics from the light: photon grid, image-space intersection estimate, splatted caustic map (Shah et al.)"
    Params = CausticMappingParams

    def caustic_passes(self, params):
        p = params

        def trace(receivers: str, views: str, channel: str, steps: int, initial: str | None = None) -> TracePhotons:
            """The footprint pass (no ``initial``) is Newton-Raphson; the second landing the parameters' estimator."""
            estimator = (p.estimator if initial else "newton", steps)
            return TracePhotons(receivers, views, channel, p, initial=initial, estimator=estimator)

        front = LightSurfaces("caster_views", "caster_front", kinds=("diffuse", "glass", "mirror"), faces="front")
        return [landing_chain("caustic-mapping", p, [front], trace, caster_size=p.photon_grid, map_size=p.map_size,
                              steps=p.iterations, splat=p.splat, splat_radius=p.splat_radius, point_map=p.point_map)]
