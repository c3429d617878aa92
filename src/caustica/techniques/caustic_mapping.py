"""``caustic-mapping``: caustics by image-space photon tracing from the light (Shah et al.).

Shah, Konttinen and Pattanaik, "Caustics Mapping: An Image-space Technique for Real-time Caustics" (TVCG 2007).
Per light sample (``passes/caustics/light_space.py``, ``landing_chain``, which ``photon-splats`` shares):

1. The casters (glass and mirrors) are rendered from the light into a view fitted around them (III-B): front
   faces of every object, back faces of the glass; one photon per covered texel, carrying the light's exact flux
   through that texel (III-E, with exact Fresnel transmittance per channel).
2. :class:`TracePhotons` (``caustic_trace.comp``) refracts each photon at the front face and leaves closed glass
   through the back faces (III-A, III-C; Wyman's d_V refined by ``exit_iterations`` regula falsi steps), reflects
   it inside convex glass on total internal reflection (``exit_reflections``, ours), through a second layer
   (``second_layer``, ours) or off a mirror, attenuates it (Beer-Lambert, III-E eq. 7), and lands it on the
   receivers' position texture by the intersection estimate (III-C, III-D; ``estimator``).
3. The photons land first on a coarse view of the receivers; the caustic map's view is fitted around those
   landings (III-F) and they are traced again, then splatted as Gaussians sized by their footprints (III-F).
4. With ``adaptive_levels``, :class:`AdaptivePhotons` refines the photon grid where the caustic has detail
   (Wyman and Nichols 2009) and :class:`ExpandPhotons` splats the finest grid.

Approximate: the exit point through the back buffer (one layer: concave or overlapping refractors exit wrongly),
photons dropped at exit TIR in nonconvex glass (and after ``exit_reflections`` in convex glass), the intersection
estimate (near receiver discontinuities it can land on the wrong surface, as the paper notes for reflections), the
first caster layer only (``second_layer`` follows glass then glass), one photon per grid texel (the footprint
splats blur the caustic to the photons' spacing), Fresnel-reflected light off glass is not splatted. Limits:
receivers must be seen from the light (one receiver layer); at most 32 casters.

Each step in full, and the figures behind the extensions: docs/caustic-mapping.md.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import TechniqueError
from ..gpu.meshes import bind_samplers, set_uniform
from ..gpu.shaders import run_compute
from ..passes.caustics.casters import MAX_CASTERS, caster_code, casters, half_diagonal, length_unit
from ..passes.caustics.light_space import (PHOTON_BYTES, FitCausticViews, LightSurfaces, Photons, dispatch_photons,
                                           landing_chain, listed)
from ..passes.caustics.light_views import bind_views
from ..passes.shading.glass_contact import bind_caster_contacts
from ..render.frame import Channel, Frame, Pass
from .base import param
from .composite import POINT_MAPS, SPLATS, CausticTechnique
from .env_map import ShadowedParams

ESTIMATORS = {"iterate": 0, "newton": 1}
EXIT_SURFACES = {"nearest": "nearest-back", "farthest": "back"}  # exit_surface -> LightSurfaces faces


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
    exit_surface: str = param("nearest", choices=tuple(EXIT_SURFACES), paper="Wyman, Fixing Problem Cases",
                              help="the back faces photons leave a refractor through: the nearest (where light "
                                   "that entered meets the glass's far side first) or the farthest (Wyman's)")
    second_layer: bool = param(False, help="photons that leave a refractor through its nearest back faces and "
                                           "meet its second layer (the next front faces from the light) enter "
                                           "it and leave through its farthest back faces: four interfaces")
    exit_reflections: int = param(2, range=(0, 8),
                                  help="our extension: total internal reflections at the exit a photon may take "
                                       "inside convex glass before it leaves through the faces seen from the light "
                                       "(0: dropped, the paper)")
    exit_iterations: int = param(6, range=(0, 64), paper="Wyman, eq. 6.3.1",
                                 help="regula falsi steps refining d_V against the back faces (0: d_V alone)")
    splat: str = param("auto", choices=SPLATS, help="'compute' (fixed-point atomics), 'points' (additive point sprites) or 'auto'")
    splat_radius: float = param(1.5, range=(0.75, 8.0), unit="texels", paper="Shah et al. III-F",
                                help="Gaussian splat radius in caustic-map texels (sigma = radius / 2)")
    point_map: str = param("frustum", choices=POINT_MAPS, paper="Shah et al. III-F",
                           help="point lights: 'frustum' (fitted, cube when too wide) or 'cube' (always)")
    adaptive_levels: int = param(0, range=(0, 5), paper="Wyman and Nichols 2009",
                                 help="refinement levels: photons start on a photon_grid / 2^levels grid and split "
                                      "in four where the caustic has detail (0: the regular grid)")
    adaptive_threshold: float = param(0.5, range=(0.01, 64.0), unit="texels", paper="Wyman and Nichols 2009",
                                      help="refine a photon whose landing bends by more than this across its cell")

    def __post_init__(self):
        super().__post_init__()
        self.photon_grid = self.photon_grid or self.map_size
        if self.second_layer and (self.exit_surface != "nearest" or self.adaptive_levels):
            raise TechniqueError("second_layer needs exit_surface 'nearest' and adaptive_levels 0: set those, or "
                                 "second_layer false")
        coarsest = self.photon_grid >> self.adaptive_levels
        if self.adaptive_levels and (coarsest << self.adaptive_levels != self.photon_grid or coarsest < 8):
            raise TechniqueError(f"adaptive_levels {self.adaptive_levels} needs photon_grid ({self.photon_grid}) "
                                 f"divisible by 2^{self.adaptive_levels} into at least 8 photons a side: give "
                                 f"photon_grid = 8 x 2^levels or more, a multiple of 2^levels, or fewer levels")


class TracePhotons(Pass):
    """One photon per caster texel: refract or reflect, estimate where it lands (Shah et al. III-C/D).

    With ``adaptive_levels`` > 0 it traces the coarsest level's cells (:class:`AdaptivePhotons`: one
    photon per block of 2^levels caster texels a side)."""

    def __init__(self, receivers: str, receiver_views: str, channel: str, params: CausticMappingParams,
                 initial: str | None = None, estimator: tuple[str, int] | None = None):
        """``initial``: photons of an earlier pass (same grid) whose landing points are the first guesses;
        ``estimator``: (name, iterations) instead of the parameters'."""
        self.receivers, self.receiver_views, self.channel, self.params = receivers, receiver_views, channel, params
        self.initial = initial
        self.estimator = estimator or (params.estimator, params.iterations)
        self.reads = ("light_samples", "caster_views", "caster_front", "caster_back", receivers, receiver_views)
        self.layered = params.second_layer
        self.reads += ("caster_second_front", "caster_far_back") if self.layered else ()
        self.reads += (initial,) if initial else ()
        self.writes = (Channel(channel, "buffer[light]", "per light: Photons (landing point, flux) or None"),)

    def program(self, frame: Frame, estimator: tuple[str, int]):
        """The photon compute program with the casters' materials and ``estimator`` set; its channel count."""
        scene, p = frame.scene, self.params
        types, iors, sigmas, colors = (np.zeros(MAX_CASTERS, "i4"), np.ones((MAX_CASTERS, 3), "f4"),
                                       np.zeros((MAX_CASTERS, 3), "f4"), np.zeros((MAX_CASTERS, 3), "f4"))
        reflections = np.zeros(MAX_CASTERS, "i4")
        dispersive = False
        objects = casters(scene)
        for i, obj in enumerate(objects):
            material = obj.material
            types[i] = caster_code(obj)
            if material.kind == "mirror":
                colors[i] = material.color
            else:
                iors[i], sigmas[i] = material.ior_rgb, material.absorption_coefficient
                dispersive |= bool(np.ptp(material.ior_rgb) > 0)
                # The front and back faces seen from the light bound a convex solid exactly, so a photon
                # reflected inside finds its way out; in a nonconvex one it meets other parts' layers.
                reflections[i] = p.exit_reflections if obj.mesh.is_convex() else 0
        channels = 3 if dispersive else 1
        defines = {"VIEW_COUNT": 2, "MAX_CASTERS": MAX_CASTERS, "ADAPTIVE": int(p.adaptive_levels > 0)}
        program = frame.gpu.shaders.compute("passes/caustics/caustic_trace.comp", defines)
        set_uniform(program, "caster_type", types)
        set_uniform(program, "caster_ior", iors)
        set_uniform(program, "caster_sigma", sigmas)
        set_uniform(program, "caster_color", colors)
        set_uniform(program, "channel_count", channels)
        set_uniform(program, "iterations", estimator[1])
        set_uniform(program, "exit_iterations", p.exit_iterations)
        set_uniform(program, "exit_reflections", reflections)
        bind_caster_contacts(program, scene, objects, MAX_CASTERS)
        set_uniform(program, "second_layer", int(self.layered))
        set_uniform(program, "estimator", ESTIMATORS[estimator[0]])
        set_uniform(program, "fallback_distance", half_diagonal(scene.objects))
        set_uniform(program, "length_unit", length_unit(scene))
        return program, channels

    def trace(self, frame: Frame, program, channels: int, caster_view, front, back, receivers, receiver_view,
              initial, level: int = 0, parent=None, layers=None) -> Photons:
        """Photons of one light: one per caster texel, or per cell of adaptive ``level`` (``parent``: the
        level above's photons, whose states say which cells to trace)."""
        levels = self.params.adaptive_levels
        bind_views(program, [caster_view, receiver_view])
        textures = (*front, *back, receivers[0]) if back is not None else (*front, *front, receivers[0])
        bind_samplers(program, ("front_position", "front_normal", "back_position", "back_normal",
                                "receiver_position"), textures)
        # The second layer (second_layer): its front faces and the farthest back faces, else placeholders.
        second, far = layers if layers is not None else ((front[0], front[1]), (front[0], front[1]))
        bind_samplers(program, ("second_position", "second_normal", "far_position", "far_normal"),
                      (*second, *far), first_unit=len(textures))
        width, height = caster_view.atlas_size
        if levels:
            block = 1 << (levels - level)
            width, height = width // block, height // block
            set_uniform(program, "level", level)
            set_uniform(program, "last_level", levels)
            set_uniform(program, "block", block)
            (parent.buffer if parent is not None else initial.buffer if initial is not None else
             self._placeholder(frame)).bind_to_storage_buffer(2)
        return dispatch_photons(frame, program, (width, height), width * height * channels, initial,
                                {"channels": channels, "level": level})

    @staticmethod
    def _placeholder(frame: Frame):
        """A buffer for the adaptive parent binding where no level lies above (unread there)."""
        return frame.own(frame.gpu.ctx.buffer(reserve=PHOTON_BYTES))

    def run(self, frame: Frame) -> None:
        program, channels = self.program(frame, self.estimator)
        out = []
        lights = len(frame.read("caster_views"))
        initials = frame.read(self.initial) if self.initial else [None] * lights
        layers = zip(frame.read("caster_second_front"), frame.read("caster_far_back")) if self.layered \
            else [None] * lights
        for caster_view, front, back, receivers, receiver_view, initial, layer in zip(
                frame.read("caster_views"), frame.read("caster_front"), frame.read("caster_back"),
                frame.read(self.receivers), frame.read(self.receiver_views), initials, layers):
            if caster_view is None or receivers is None or receiver_view is None:
                out.append(None)
                continue
            out.append(self.trace(frame, program, channels, caster_view, front, back, receivers, receiver_view,
                                  initial, layers=layer))
        frame.write(self.channel, out)


class AdaptivePhotons(TracePhotons):
    """Adaptive caustic maps (Wyman and Nichols 2009, "Adaptive Caustic Maps Using Deferred Shading").

    Written from the idea of the paper (not in shared/papers) and our own reading: photons start on a
    coarse light-space grid, one per block of 2^L caster texels a side (L = ``adaptive_levels``; the caster
    textures are drawn once, at ``photon_grid``, so every level looks up the same deferred buffers) and
    leave from the block's centre; level by level, a photon splits into four at half the spacing, each
    carrying the flux of its quarter (a cell's photon carries the summed flux of its block's texels that
    see its caster, so the children's flux sums to the parent's), where its cell lies on a caster's rim,
    its photon was lost, or its landing departs from the linear model of its footprint splat by more
    than ``adaptive_threshold`` caustic-map texels (``caustic_refine.comp``). Cells that miss every caster
    are culled. The cells next to refined ones are traced as helpers: the footprints and the refinement
    test read their landing points.

    As the regular grid, every level lands twice: first (``first``: the coarsest level, landed already)
    on the coarse receivers with Newton-Raphson, refining against ``refine_views`` (a caustic view fitted
    around the coarsest landings), so that the caustic map's view is then fitted around the live photons
    of every level; then (``initial``: the first landing's levels) on the caustic map's receivers, keeping
    the first landing's states. Writes per light the list of levels' Photons (ExpandPhotons puts their
    live photons on the finest grid for the splat).
    """

    def __init__(self, receivers: str, receiver_views: str, channel: str, params: CausticMappingParams,
                 estimator: tuple[str, int], *, first: str | None = None, refine_views: str | None = None,
                 initial: str | None = None):
        super().__init__(receivers, receiver_views, channel, params, initial=initial, estimator=estimator)
        self.first, self.refine_views = first, refine_views
        self.reads += tuple(name for name in (first, refine_views) if name)
        self.writes = (Channel(channel, "buffer[light]", "per light: Photons of each refinement level, or None"),)

    def run(self, frame: Frame) -> None:
        program, channels = self.program(frame, self.estimator)
        levels = self.params.adaptive_levels
        lights = len(frame.read("caster_views"))
        firsts = frame.read(self.first) if self.first else [None] * lights
        refine_views = frame.read(self.refine_views) if self.refine_views else [None] * lights
        initials = frame.read(self.initial) if self.initial else [None] * lights
        out = []
        for caster_view, front, back, receivers, receiver_view, first, refine_view, initial in zip(
                frame.read("caster_views"), frame.read("caster_front"), frame.read("caster_back"),
                frame.read(self.receivers), frame.read(self.receiver_views), firsts, refine_views, initials):
            if caster_view is None or receivers is None or receiver_view is None or (first is None and initial is None):
                out.append(None)
                continue
            textures = (caster_view, front, back, receivers, receiver_view)
            photons = []
            for level in range(levels + 1):
                # The second landing: from the first's landing points, with its states.
                if initial is not None:
                    photons.append(self.trace(frame, program, channels, *textures, initial[level], level,
                                              initial[level - 1] if level else None))
                    continue
                # The first: cells whose parents were refined, then mark the live ones that bend.
                photons.append(first if level == 0 else
                               self.trace(frame, program, channels, *textures, None, level, photons[-1]))
                if level < levels and refine_view is not None:
                    self._refine(frame, photons[-1], refine_view, channels)
            out.append(photons)
        frame.write(self.channel, out)

    def _refine(self, frame: Frame, photons: Photons, view, channels: int) -> None:
        """caustic_refine.comp over one level's cells, bends measured in ``view``'s texels."""
        program = frame.gpu.shaders.compute("passes/caustics/caustic_refine.comp")
        width, height = photons.grid
        view.bind(program)
        set_uniform(program, "grid", (width, height))
        set_uniform(program, "channels", channels)
        set_uniform(program, "threshold", float(self.params.adaptive_threshold))
        photons.buffer.bind_to_storage_buffer(0)
        run_compute(program, (width + 7) // 8, (height + 7) // 8)
        frame.gpu.ctx.memory_barrier()


class ExpandPhotons(Pass):
    """The adaptive levels' live photons spread over the finest grid (``caustic_expand.comp``): each splits
    into the finest cells of its block along the first-order model of its landing, so every photon the
    splat sees lies on one grid and the footprint splats sum flat across the levels' edges."""

    def __init__(self, levels: str, channel: str):
        self.levels, self.channel = levels, channel
        self.reads = (levels,)
        self.writes = (Channel(channel, "buffer[light]", "per light: Photons on the finest grid, or None"),)

    def run(self, frame: Frame) -> None:
        program = frame.gpu.shaders.compute("passes/caustics/caustic_expand.comp")
        out = []
        for levels in frame.read(self.levels):
            if levels is None:
                out.append(None)
                continue
            finest = levels[-1]
            buffer = frame.own(frame.gpu.ctx.buffer(reserve=finest.count * PHOTON_BYTES))
            buffer.clear()
            buffer.bind_to_storage_buffer(1)
            for photons in levels:
                width, height = photons.grid
                photons.buffer.bind_to_storage_buffer(0)
                set_uniform(program, "grid", (width, height))
                set_uniform(program, "block", finest.grid[1] // height)
                set_uniform(program, "channels", photons.channels)
                run_compute(program, (width + 7) // 8, (height + 7) // 8)
                frame.gpu.ctx.memory_barrier()
            out.append(Photons(buffer, finest.count, dict(finest.stats), finest.grid, finest.channels))
        frame.write(self.channel, out)


class CountPhotons(Pass):
    """How many photons each light splats, per adaptive level (one entry on the regular grid), counted on
    the GPU (a 4-byte readback per level), for the benchmarks and the tests of adaptive refinement."""

    writes = (Channel("photon_counts", "host[light]", "per light: live photons of each level, or None"),)

    def __init__(self, photons: str = "photons"):
        self.photons = photons
        self.reads = (photons,)

    def run(self, frame: Frame) -> None:
        frame.write("photon_counts", [None if photons is None else
                                      [level.live(frame) for level in listed(photons)]
                                      for photons in frame.read(self.photons)])


class CausticMapping(CausticTechnique):
    name = "caustic-mapping"
    summary = "Caustics from the light: photon grid, image-space intersection estimate, splatted caustic map (Shah et al.)"
    Params = CausticMappingParams

    def caustic_passes(self, params):
        p = params

        def trace(receivers: str, views: str, channel: str, steps: int, initial: str | None = None) -> TracePhotons:
            """The footprint pass (no ``initial``) is Newton-Raphson; the second landing the parameters' estimator
            (with adaptive levels, every level's two landings: AdaptivePhotons)."""
            estimator = (p.estimator if initial else "newton", steps)
            if not p.adaptive_levels:
                return TracePhotons(receivers, views, channel, p, initial=initial, estimator=estimator)
            if initial:
                return [AdaptivePhotons(receivers, views, "photon_levels", p, estimator, initial=initial),
                        ExpandPhotons("photon_levels", channel)]
            # The coarsest level, a caustic view around it to measure bends in, then the finer levels.
            return [TracePhotons(receivers, views, "coarsest_photons", p, estimator=estimator),
                    FitCausticViews("coarsest_photons", p.map_size, margin_texels=p.splat_radius + 2.0,
                                    point_map=p.point_map, channel="refine_views"),
                    AdaptivePhotons(receivers, views, channel, p, estimator, first="coarsest_photons",
                                    refine_views="refine_views")]

        front = LightSurfaces("caster_views", "caster_front", kinds=("diffuse", "glass", "mirror"), faces="front")
        makers = [front]
        if p.second_layer:
            makers += [LightSurfaces("caster_views", "caster_second_front", kinds=("glass",), faces="front",
                                     peel="caster_back"),
                       LightSurfaces("caster_views", "caster_far_back", kinds=("glass",), faces="back")]
        return [landing_chain("caustic-mapping", p, makers, trace, caster_size=p.photon_grid, map_size=p.map_size,
                              steps=p.iterations, splat=p.splat, splat_radius=p.splat_radius, point_map=p.point_map,
                              extra=[CountPhotons("photon_levels" if p.adaptive_levels else "photons")],
                              back=EXIT_SURFACES[p.exit_surface])]
