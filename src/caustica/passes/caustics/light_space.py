"""Light-space passes of the caustic techniques: photons from the light into caustic maps (Shah et al.; Wyman).

Both caustic papers render the scene *from the light*: Shah et al., "Caustics
Mapping: An Image-space Technique for Real-time Caustics" (III-B) render the
receivers' world positions and the refractors' positions and normals into
light-space textures, trace one photon per refractor texel, splat the photons
into a light-space caustic map with additive blending (III-F) and project the
map onto receivers like a shadow map; Wyman's photon splats follow the same
outline. This module holds the passes they share, each declaring its channels
(one list entry per light sample, None where a light makes no caustic); the
views they draw in are ``passes/caustics/light_views.py``, the cache across frames
``render/cached.py``:

- :class:`FitCasterViews` (III-B: the photon grid's view around the casters),
  :class:`FitCoarseViews` and :class:`FitCausticViews` (III-F, "view frustum
  limitation": a view over the whole scene, then one fitted tightly around
  where the photons landed).
- :class:`LightSurfaces` (III-B, first two passes: position + distance and
  normal textures of chosen objects and faces: receivers, caster fronts,
  refractor backs).
- :class:`SplatPhotons` (III-C, III-F: compute shader with integer atomics on
  fixed-point sums, ``passes/caustics/fixed_flux.py``, where GL_NV_shader_atomic_float
  exists, else Gaussian point sprites with additive blending into three r32f
  targets: the same kernel, so both deposit the same flux; either way the
  bytes do not depend on thread scheduling). Photons made on a grid get
  Gaussians sized by their footprints (``caustic_footprint.comp``).
- :class:`ResolveCausticMaps` (irradiance = flux / receiver area of the texel,
  alpha = the receiver's distance to the light, into the ``caustic_maps``
  contract of ``passes/caustics/maps.py``).
- :func:`landing_chain`: the whole sequence from the light to the caustic maps,
  once for ``caustic-mapping`` and ``photon-splats``, which differ only in how
  they make and land the photons.

Photons live in :class:`Photons`: an SSBO of ``{vec4 position (w = 1 landed);
vec4 flux (W, RGB)}``, the format every splat here reads, with the light-space
grid they were made on where there is one; :func:`dispatch_photons` runs a
compute shader that writes one (``photon_land.comp``).
"""
from __future__ import annotations

from contextlib import ExitStack
from dataclasses import dataclass, field

import moderngl
import numpy as np

from ...gpu.meshes import bind_samplers, set_object_transform, set_uniform
from ...gpu.shaders import run_compute
from ...render.cached import CachedPasses
from ...render.frame import Channel, Frame, Pass
from ..shading.shadows import LIGHT_DIRECTIONAL, LIGHT_POINT
from .fixed_flux import splat_fixed_point
from .light_views import LightView, caster_points, coarse_view, cube_view, fit_view

PHOTON_BYTES = 32  # vec4 position + vec4 flux
# The fewest Newton-Raphson steps of the first landing, on the coarse views: it converges, so the caustic
# view fitted around the landed photons holds the caustic (caustic-mapping's footprint pass, photon-splats).
COARSE_NEWTON_STEPS = 6
COARSE_MAP_SIZE = 256  # texels a side of the coarse views at most
# Footprint splats (SplatPhotons, caustic_footprint.comp): a photon's sigma per landed grid cell (a regular
# grid under a 3-sigma Gaussian of 0.7 cells sums flat to a few 1e-3), and the largest sigma (texels).
FOOTPRINT_SCALE = 0.7
FOOTPRINT_CAP = 32.0
# FitCausticViews: the flux fraction a side the widened caustic view lets go at least (a few stray photons of
# a 512^2 grid) and in photons' shares of the grid, how many times its texels a side may grow to keep the
# core's density, and the most texels a side it grows to.
HALO_TRIM = 1e-5
MAX_VIEW_GROWTH = 2.0
MAX_GROWN_SIZE = 2048
STRAY_PHOTONS = 5.0
@dataclass
class Photons:
    """Photons in an SSBO: ``count`` entries of {vec4 position (w = 1 landed), vec4 flux (W, RGB)}."""

    buffer: object
    count: int
    stats: dict = field(default_factory=dict)
    # The light-space grid the photons were made on, (width, height) texels (a cube atlas: six faces of
    # height texels side by side), entry (row * width + column) * channels + channel; None: no grid
    # (then SplatPhotons cannot size splats by footprint).
    grid: tuple[int, int] | None = None
    channels: int = 1

    def live(self, frame: Frame) -> int:
        """How many photons landed and are splatted (adaptive levels: live cells, adaptive_states.glsl),
        counted on the GPU (``photon_count.comp``)."""
        program = frame.gpu.shaders.compute("passes/caustics/photon_count.comp")
        with frame.scoped(frame.gpu.ctx.buffer(np.zeros(1, "u4").tobytes())) as counter:
            set_uniform(program, "photon_count", int(self.count))
            self.buffer.bind_to_storage_buffer(0)
            counter.bind_to_storage_buffer(1)
            run_compute(program, (self.count + 63) // 64)
            frame.gpu.ctx.memory_barrier()
            return int(np.frombuffer(counter.read(), "u4")[0])

    def read(self, live: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """(positions (n, 3), flux (n, 3)) of the photons that landed (``live``: and are splatted,
        adaptive_states.glsl)."""
        data = np.frombuffer(self.buffer.read(size=self.count * PHOTON_BYTES), dtype="f4").reshape(-1, 8)
        landed = (data[:, 3] > 0.5) & ((data[:, 7] == 0.0) if live else True)
        return data[landed, :3].astype(np.float64), data[landed, 4:7].astype(np.float64)


def dispatch_photons(frame: Frame, program, size: tuple[int, int], count: int, initial: Photons | None,
                     stats: dict) -> Photons:
    """Run a photon compute shader over a ``size`` texel grid (8 x 8 groups) into a new buffer of ``count``
    photons (binding 0); binding 1 holds the ``initial`` photons (``has_initial``), or the new buffer."""
    buffer = frame.own(frame.gpu.ctx.buffer(reserve=count * PHOTON_BYTES))
    buffer.bind_to_storage_buffer(0)
    set_uniform(program, "has_initial", int(initial is not None))
    (initial.buffer if initial is not None else buffer).bind_to_storage_buffer(1)
    # The photon exits were rendered just before: without a barrier llvmpipe may run the dispatch while its
    # rasterizer threads still write them (photon-splats' images then differed between processes).
    frame.gpu.ctx.memory_barrier()
    run_compute(program, (size[0] + 7) // 8, (size[1] + 7) // 8)
    frame.gpu.ctx.memory_barrier()
    width, height = int(size[0]), int(size[1])
    return Photons(buffer, count, stats, (width, height), max(count // max(width * height, 1), 1))


# Passes -----------------------------------------------------------------------


class FitCasterViews(Pass):
    """The photon grid's view of each light: fitted around the casters (Shah et al. III-B, second pass).

    Directional and spot lights, and point lights whose casters fit one
    frustum, get a projective view aimed at the casters; other point lights
    (or ``point_map='cube'``) the six-face atlas. None where a light sees no caster.
    """

    reads = ("light_samples",)
    writes = (Channel("caster_views", "host[light]", "per light: LightView of the photon grid, or None"),)

    def __init__(self, size: int, kinds=("glass", "mirror"), point_map: str = "frustum"):
        self.size, self.kinds, self.point_map = int(size), tuple(kinds), point_map

    def run(self, frame: Frame) -> None:
        casters = [o for o in frame.scene.objects if o.material.kind in self.kinds]
        points = caster_points(casters)
        views = []
        for sample in frame.read("light_samples"):
            view = None
            if len(points):
                if sample.type != LIGHT_POINT or self.point_map != "cube":
                    view = fit_view(sample, points, self.size, frame.scene, margin_texels=1.0)
                if view is None and sample.type == LIGHT_POINT:
                    view = cube_view(sample, self.size, frame.scene)
                if view is None:  # a spot light whose casters spread wider than a frustum: the atlas
                    view = coarse_view(sample, self.size, frame.scene)
            views.append(view)
        frame.write("caster_views", views)


class LightSurfaces(Pass):
    """Positions and normals of chosen objects from each light view (Shah et al. III-B, first two passes).

    Writes, per light, a pair of pooled rgba32f textures laid out in the view:
    world xyz + distance to the light (0: empty) and outward world normal +
    object code (index + 1 in ``coded`` for caster objects, 0 for the rest).
    ``faces`` 'front' keeps the nearest front faces, 'back' the farthest back
    faces (Wyman's back-face buffer), 'nearest-back' the nearest back faces
    (where light that entered leaves first). Receivers: the diffuse objects'
    front faces; caster fronts: every object (the rest occlude the grid).
    ``peel`` (a channel of the same kind, same views) keeps only what lies
    farther from the light than its surface at each texel: with 'front', the
    glass's second layer of front faces behind its nearest back faces.
    """

    reads = ()

    def __init__(self, views: str, channel: str, kinds=("diffuse",), faces: str = "front", coded=("glass", "mirror"),
                 peel: str | None = None):
        self.views, self.channel, self.kinds, self.faces, self.coded = views, channel, tuple(kinds), faces, tuple(coded)
        self.peel = peel
        self.reads = (views,) + ((peel,) if peel else ())
        self.writes = (Channel(channel, "rgba32f x2[light]", f"per light: (position+distance, normal+code) of {faces} "
                                                             f"faces of {'/'.join(self.kinds)} objects"),)

    def run(self, frame: Frame) -> None:
        peels = frame.read(self.peel) if self.peel else [None] * len(frame.read(self.views))
        frame.write(self.channel, [None if v is None else self.render(frame, v, peel)
                                   for v, peel in zip(frame.read(self.views), peels)])

    def render(self, frame: Frame, view: LightView, peel=None):
        gpu = frame.gpu
        position, normal = frame.texture(view.atlas_size, "rgba32f"), frame.texture(view.atlas_size, "rgba32f")
        with frame.scratch(view.atlas_size, "depth") as depth:
            self._draw(frame, view, gpu.targets.framebuffer([position, normal], depth), peel)
        return position, normal

    def _draw(self, frame: Frame, view: LightView, fbo, peel=None) -> None:
        gpu, ctx = frame.gpu, frame.gpu.ctx
        fbo.use()
        back, farthest = self.faces != "front", self.faces == "back"
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=0.0 if farthest else 1.0)
        program = gpu.shaders.program("common/mesh_vertex.glsl", "passes/caustics/caustic_surface.frag",
                                      {"ALONG_DIRECTION": int(view.sample.type == LIGHT_DIRECTIONAL),
                                       "PEEL": int(self.peel is not None)})
        if self.peel is not None:
            bind_samplers(program, ("peel",), (peel[0],))
        set_uniform(program, "origin", np.asarray(view.sample.position, "f4"))
        set_uniform(program, "direction", np.asarray(view.sample.direction, "f4"))
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = ">" if farthest else "<"
        if back:
            ctx.enable(moderngl.CULL_FACE)
            ctx.front_face, ctx.cull_face = "ccw", "front"
        else:
            ctx.disable(moderngl.CULL_FACE)  # open meshes (water) are seen from either side
        casters = [o for o in frame.scene.objects if o.material.kind in self.coded]
        for face in range(view.faces):
            fbo.viewport = (face * view.size, 0, view.size, view.size)
            set_uniform(program, "clip_from_world", view.clips[face])
            for obj in frame.scene.objects:
                if obj.material.kind not in self.kinds:
                    continue
                code = casters.index(obj) + 1 if obj in casters else 0
                set_uniform(program, "object_code", float(code))
                set_object_transform(program, obj.world_from_object())
                gpu.meshes.get(obj.mesh).render(program)
        ctx.depth_func = "<"
        ctx.cull_face = "back"
        ctx.disable(moderngl.CULL_FACE)


class FitCoarseViews(Pass):
    """A first receiver view of each light over the whole scene (:func:`coarse_view`), to find the footprint."""

    reads = ("light_samples",)
    writes = (Channel("coarse_views", "host[light]", "per light: LightView over the whole scene"),)

    def __init__(self, size: int):
        self.size = int(size)

    def run(self, frame: Frame) -> None:
        frame.write("coarse_views", [coarse_view(s, self.size, frame.scene) for s in frame.read("light_samples")])


class FitCausticViews(Pass):
    """The caustic map's view of each light, fitted tightly around where its photons landed.

    Shah et al. III-F: caustics outside the light's frustum are lost, and a map
    spread over the whole receiver blurs the focus. Landing points come from a
    first photon pass against ``coarse_view`` receivers. The flux-weighted
    ``trim`` fraction at each side sets the texel density (``size`` texels
    over that core); for point and spot lights the view then widens to let
    only ``halo_trim`` go (or STRAY_PHOTONS photons' share of a sparse grid),
    with texels added to keep that density, up to ``max_growth`` times
    ``size`` a side (``halo_trim`` None, the default: the core's view;
    :func:`landing_chain` gives HALO_TRIM): a per-axis trim alone would cut a
    ball's outer halo along a square under a close light (tests/test_caustic_views.py;
    docs/measured-defaults.md). Point lights fall back
    to the cube atlas when the landing points spread wider than one frustum.
    """

    def __init__(self, photons: str, size: int, margin_texels: float = 3.0, trim: float = 1e-3, point_map: str = "frustum",
                 channel: str = "caustic_views", halo_trim: float | None = None, max_growth: float = MAX_VIEW_GROWTH):
        self.photons, self.size, self.margin, self.trim = photons, int(size), margin_texels, trim
        self.point_map, self.halo_trim, self.max_growth = point_map, halo_trim, max_growth
        self.reads = ("light_samples", photons)
        self.writes = (Channel(channel, "host[light]", "per light: LightView of the caustic map, or None"),)

    def run(self, frame: Frame) -> None:
        views = []
        for sample, photons in zip(frame.read("light_samples"), frame.read(self.photons)):
            view = None
            if photons is not None and sample.type == LIGHT_POINT and self.point_map == "cube":
                view = cube_view(sample, self.size, frame.scene)
            elif photons is not None:
                # Adaptive levels (a list): the live photons of every level.
                levels = [level.read(live=True) for level in photons] if isinstance(photons, list) else [photons.read()]
                points, flux = np.concatenate([p for p, _ in levels]), np.concatenate([f for _, f in levels])
                weights = flux.sum(axis=1)
                keep = weights > 0
                if keep.any():
                    view = self.fit(sample, points[keep], weights[keep], frame.scene, listed(photons)[-1].count)
                    if view is None:
                        view = cube_view(sample, self.size, frame.scene) if sample.type == LIGHT_POINT else \
                            coarse_view(sample, self.size, frame.scene)
            views.append(view)
        frame.write(self.writes[0].name, views)

    def fit(self, sample, points: np.ndarray, weights: np.ndarray, scene, grid_photons: int) -> LightView | None:
        """The view around the core (``trim``) widened to the halo (``halo_trim``) at the core's texel density."""
        core = fit_view(sample, points, self.size, scene, self.margin, weights, self.trim)
        # Let go at least STRAY_PHOTONS photons' share of the (finest) grid: a sparse grid's strays would
        # widen it alone.
        halo_trim = None if self.halo_trim is None else max(self.halo_trim, STRAY_PHOTONS / max(grid_photons, 1))
        # Parallel light: the halo stays near the casters' shadow.
        if sample.type == LIGHT_DIRECTIONAL or halo_trim is None or halo_trim >= self.trim:
            return core
        halo = fit_view(sample, points, self.size, scene, self.margin, weights, halo_trim)
        if core is None or halo is None:
            return core
        widening = np.sqrt(halo.unit_area / max(core.unit_area, 1e-300))
        size = int(min(np.ceil(self.size * widening / 8.0) * 8, self.max_growth * self.size, MAX_GROWN_SIZE))
        return fit_view(sample, points, max(size, self.size), scene, self.margin, weights, halo_trim)


def float_atomics(frame: Frame) -> bool:
    """Whether this GL has imageAtomicAdd on r32f images (GL_NV_shader_atomic_float): where
    :class:`SplatPhotons`' 'auto' picks the compute splat (which itself needs only GL 4.3)."""
    return bool(frame.gpu.info.get("float_atomics"))


class SplatPhotons(Pass):
    """Photons into per-texel flux (Shah et al. III-C and III-F: additive point splats, Gaussian fall-off).

    ``mode`` 'compute' adds with integer atomics into 64-bit fixed-point sums
    (``passes/caustics/fixed_flux.py``: order-independent, so the same photons give the
    same bytes; core GL 4.3), 'points' draws additive Gaussian point sprites
    (blending in primitive order: deterministic too), 'auto' picks compute
    where GL_NV_shader_atomic_float exists, else points. Both use the same normalised kernels, so a
    photon deposits exactly its flux whichever path runs. Writes three r32f
    textures per light.

    Kernels: photons made on a light-space grid (``Photons.grid``: caustic-mapping,
    photon-splats) get footprint splats (``caustic_footprint.comp``): a Gaussian
    of covariance sigma0^2 I + FOOTPRINT_SCALE^2 J J^T, sigma0 = ``radius`` / 2 and
    J the ray differential of the landing point over the grid (from the grid
    neighbours' landing points), cut at 3 sigma. A regular photon grid splatted
    with a fixed kernel beats against the map's texels (moire rings)
    wherever the photons land about a texel apart or more; footprint splats
    cover each photon's landed cell and sum flat there. Degenerate footprints
    (grazing photons landing far apart) are clamped to FOOTPRINT_CAP texels a
    sigma, the photon's flux scaled by the kept fraction of its footprint area.
    Other photons (no grid: transport-table) get caustic_light_space.glsl's
    fixed kernel (sigma = ``radius`` / 2, cut at 2 sigma).
    """

    def __init__(self, photons: str, views: str = "caustic_views", mode: str = "auto", radius: float = 1.5):
        self.photons, self.views, self.mode, self.radius = photons, views, mode, float(radius)
        self.reads = (photons, views)
        self.writes = (Channel("caustic_flux", "r32f x3[light]", "per light: three textures of flux (W) per caustic-map texel"),)

    def run(self, frame: Frame) -> None:
        mode = self.mode
        if mode == "auto":
            mode = "compute" if float_atomics(frame) else "points"
        out = []
        for view, photons in zip(frame.read(self.views), frame.read(self.photons)):
            if view is None or photons is None:
                out.append(None)
                continue
            # One Photons, or the levels of an adaptive map (each level's footprints from its own grid).
            levels = listed(photons)
            with ExitStack() as stack:
                footprints = [None if level.grid is None else stack.enter_context(
                    frame.scoped(self._footprints(frame, view, level))) for level in levels]
                out.append(self._splat(frame, mode, view, levels, footprints))
        frame.write("caustic_flux", out)

    def _splat(self, frame: Frame, mode: str, view: LightView, levels: list, footprints: list) -> list:
        return (self._compute if mode == "compute" else self._points)(frame, view, levels, footprints)

    def _footprints(self, frame: Frame, view: LightView, photons: Photons):
        """A buffer of vec4 per photon: its kernel's shape (A = Sigma^-1: xx, xy, yy) and flux scale."""
        buffer = frame.gpu.ctx.buffer(reserve=max(photons.count, 1) * 16)
        program = frame.gpu.shaders.compute("passes/caustics/caustic_footprint.comp")
        view.bind(program)
        width, height = photons.grid
        set_uniform(program, "grid", (width, height))
        set_uniform(program, "channels", int(photons.channels))
        set_uniform(program, "splat_radius", self.radius)
        set_uniform(program, "footprint_scale", FOOTPRINT_SCALE)
        set_uniform(program, "footprint_cap", FOOTPRINT_CAP)
        photons.buffer.bind_to_storage_buffer(0)
        buffer.bind_to_storage_buffer(1)
        run_compute(program, (width + 7) // 8, (height + 7) // 8)
        frame.gpu.ctx.memory_barrier()
        return buffer

    def _compute(self, frame: Frame, view: LightView, levels: list, footprints: list) -> list:
        def dispatch(bind, bound: int) -> None:
            for photons, footprint in zip(levels, footprints):
                defines = {"FLUX_BOUND": bound, "FOOTPRINT": int(footprint is not None)}
                program = frame.gpu.shaders.compute("passes/caustics/caustic_splat.comp", defines)
                bind(program)
                view.bind(program)
                set_uniform(program, "photon_count", int(photons.count))
                set_uniform(program, "splat_radius", self.radius)
                photons.buffer.bind_to_storage_buffer(0)
                if footprint is not None:
                    footprint.bind_to_storage_buffer(1)
                run_compute(program, (photons.count + 63) // 64)

        return splat_fixed_point(frame, view.atlas_size, dispatch)

    def _points(self, frame: Frame, view: LightView, levels: list, footprints: list) -> list:
        ctx = frame.gpu.ctx
        targets = [frame.zeroed(view.atlas_size, "r32f") for _ in range(3)]
        fbo = frame.gpu.targets.framebuffer(targets)
        fbo.use()
        fbo.viewport = (0, 0, *view.atlas_size)  # the targets came zeroed from the pool
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.enable(moderngl.BLEND | moderngl.PROGRAM_POINT_SIZE)
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        ctx.blend_equation = moderngl.FUNC_ADD
        for photons, footprint in zip(levels, footprints):
            defines = {"FOOTPRINT": int(footprint is not None)}
            program = frame.gpu.shaders.program("passes/caustics/caustic_splat.vert", "passes/caustics/caustic_splat.frag", defines)
            view.bind(program)
            set_uniform(program, "splat_radius", self.radius)
            content = [(photons.buffer, "4f 4f", "in_position", "in_flux")]
            if footprint is not None:
                content.append((footprint, "4f", "in_shape"))
            with frame.scoped(ctx.vertex_array(program, content)) as vao:
                vao.render(moderngl.POINTS, vertices=photons.count)
        ctx.disable(moderngl.BLEND | moderngl.PROGRAM_POINT_SIZE)
        ctx.blend_func = moderngl.DEFAULT_BLENDING
        return targets


class ResolveCausticMaps(Pass):
    """Flux per texel into the ``caustic_maps`` contract: irradiance = flux / receiver area, alpha = distance.

    The receiver area of a texel is its solid angle times d^2 (or its
    perpendicular area) over the cosine between the receiver normal and the
    light, from the receivers' normal texture. The maps are new textures owned
    by the caller (:class:`~caustica.render.cached.CachedPasses` keeps them across frames).
    """

    def __init__(self, receivers: str = "receivers", views: str = "caustic_views"):
        self.receivers, self.views = receivers, views
        self.reads = ("caustic_flux", receivers, views)
        self.writes = (Channel("caustic_maps", "rgba32f + host[light]", "per light: CausticMap (irradiance W/m^2, receiver distance)"),)

    def run(self, frame: Frame) -> None:
        ctx = frame.gpu.ctx
        program = frame.gpu.shaders.compute("passes/caustics/caustic_resolve.comp")
        maps = []
        for view, flux, receivers in zip(frame.read(self.views), frame.read("caustic_flux"), frame.read(self.receivers)):
            if view is None or flux is None or receivers is None:
                maps.append(None)
                continue
            texture = frame.own(ctx.texture(view.atlas_size, 4, dtype="f4"))  # nearest filtered, unlike pooled ones
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
            view.bind(program)
            bind_samplers(program, ("flux_r", "flux_g", "flux_b", "receiver_position", "receiver_normal"),
                          (*flux, *receivers))
            texture.bind_to_image(0, read=False, write=True)
            run_compute(program, (view.atlas_size[0] + 7) // 8, (view.atlas_size[1] + 7) // 8)
            ctx.memory_barrier()
            maps.append(view.caustic_map(texture))
        frame.write("caustic_maps", maps)



def listed(items) -> list:
    """One item (a pass, a light's Photons) or a list of them (passes, an adaptive map's levels), as a list."""
    return list(items) if isinstance(items, (list, tuple)) else [items]


def landing_chain(tag: str, params, makers: list, land, *, caster_size: int, map_size: int, steps: int,
                  splat: str, splat_radius: float, point_map: str = "frustum", extra: tuple = (),
                  back: str = "back") -> CachedPasses:
    """Photons made from the light, landed twice and splatted into caustic maps (Shah et al. III-B to III-F).

    1. III-B: the photon grid's view around the casters (:class:`FitCasterViews`, ``caster_size`` texels
       a side) and the refractors' back faces in it (``caster_back``: ``back`` 'back' the farthest, Wyman's
       back-face buffer, 'nearest-back' the nearest; :class:`LightSurfaces`).
    2. ``makers``: the technique's passes making, in that view, what its photons start from.
    3. The footprint: the photons landed on the receivers of a view over the whole scene
       (:class:`FitCoarseViews`, at most COARSE_MAP_SIZE texels) with at least COARSE_NEWTON_STEPS
       steps, into ``coarse_photons``.
    4. III-F, view frustum limitation: the caustic map's view fitted around where they landed
       (:class:`FitCausticViews`, ``map_size`` texels), its receivers, and the photons landed again
       ``steps`` steps from the first hits, into ``photons``.
    5. III-F: :class:`SplatPhotons` (``splat``, ``splat_radius`` texels) and :class:`ResolveCausticMaps`.

    ``land(receivers, views, channel, steps, initial=None)`` makes a landing pass or passes (photons onto the
    ``receivers`` textures laid out in ``views``, into ``channel``; first guesses where the ``initial``
    channel's photons landed; none for the footprint, which ``land`` makes Newton-Raphson). The chain reruns only when lights, objects,
    materials or ``params`` change (:class:`~caustica.render.cached.CachedPasses` ``tag``). ``extra``
    passes run last; the chain keeps what they write with the caustic maps.
    """
    kept = ("caustic_maps", *(c.name for stage in extra for c in stage.writes))
    return CachedPasses(tag, tuple(sorted(vars(params).items())), keep=kept, passes=[
        FitCasterViews(caster_size, point_map=point_map),
        LightSurfaces("caster_views", "caster_back", kinds=("glass",), faces=back),
        *makers,
        FitCoarseViews(min(map_size, COARSE_MAP_SIZE)),
        LightSurfaces("coarse_views", "coarse_receivers"),
        *listed(land("coarse_receivers", "coarse_views", "coarse_photons", max(COARSE_NEWTON_STEPS, steps))),
        FitCausticViews("coarse_photons", map_size, margin_texels=splat_radius + 2.0, point_map=point_map,
                        halo_trim=HALO_TRIM),
        LightSurfaces("caustic_views", "receivers"),
        *listed(land("receivers", "caustic_views", "photons", steps, initial="coarse_photons")),
        SplatPhotons("photons", mode=splat, radius=splat_radius),
        ResolveCausticMaps("receivers"),
        *extra,
    ])
