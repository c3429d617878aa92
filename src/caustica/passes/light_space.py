"""Light-space building blocks of the caustic techniques (Shah et al.; Wyman's photon splats).

Both caustic papers render the scene *from the light*: Shah et al., "Caustics
Mapping: An Image-space Technique for Real-time Caustics" (III-B) render the
receivers' world positions and the refractors' positions and normals into
light-space textures, trace one photon per refractor texel, splat the photons
into a light-space caustic map with additive blending (III-F) and project the
map onto receivers like a shadow map; Wyman's photon splats follow the same
outline. This module holds what they share:

- :class:`LightView`: a light-space view, projective (perspective or
  orthographic, any ``clip_from_world``) or a six-face cube atlas (6N x N, the
  layout of ``passes/lights.py``), with its texels' area at unit distance (the shaders'
  ``texel_measure``: solid angle or perpendicular area) and ``bind`` for
  ``shaders/passes/caustic_light_space.glsl``.
- Fitting (III-F, "view frustum limitation"): :func:`fit_view` fits a view
  tightly around world points as seen from the light (the casters' vertices for
  the photon grid; the photons' landing points for the caustic map, trimmed of
  a tiny flux fraction), :func:`coarse_view` covers the whole scene,
  :func:`cube_view` is the omnidirectional atlas for point lights.
- Passes, each declaring its channels (one list entry per light sample, None
  where a light makes no caustic): :class:`FitCasterViews`,
  :class:`LightSurfaces` (position + distance and normal textures of chosen
  objects and faces: receivers, caster fronts, refractor backs),
  :class:`FitCausticViews`, :class:`SplatPhotons` (compute shader with
  integer atomics on fixed-point sums, ``passes/fixed_flux.py``, where
  GL_NV_shader_atomic_float exists, else Gaussian point sprites with additive
  blending into three r32f targets: the same kernel, so both deposit the same
  flux; either way the bytes do not depend on thread scheduling),
  :class:`ResolveCausticMaps` (irradiance = flux / receiver area of the texel,
  alpha = the receiver's distance to the light, into the ``caustic_maps``
  contract of ``passes/caustics.py``), and :class:`CachedPasses`, which reruns
  a chain only when lights, objects or materials change.

Photons live in :class:`Photons`: an SSBO of ``{vec4 position (w = 1 landed);
vec4 flux (W, RGB)}``, the format every splat here reads; :func:`dispatch_photons`
runs a compute shader that writes one (``photon_land.comp``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import moderngl
import numpy as np

from ..cache import state_key
from ..gpu.meshes import bind_samplers, set_object_transform, set_uniform
from ..gpu.shaders import run_compute
from ..scene.transform import look_at_view_from_world, perspective_clip_from_view, up_hint
from .base import Channel, Frame, Pass, run_passes
from .caustics import CAUSTIC_CUBE, CAUSTIC_PROJECTIVE, CausticMap
from .fixed_flux import splat_fixed_point
from .lights import (
    CUBE_FORWARD,
    CUBE_UP,
    LIGHT_DIRECTIONAL,
    LIGHT_POINT,
    LightSample,
    scene_state_key,
)

VIEW_PROJECTIVE, VIEW_CUBE = 0, 1
MAX_PROJECTIVE_HALF_ANGLE = 60.0  # degrees: wider footprints of a point light go to the cube atlas
PHOTON_BYTES = 32  # vec4 position + vec4 flux
# The fewest Newton-Raphson steps of the first landing, on the coarse views: it converges, so the caustic
# view fitted around the landed photons holds the caustic (caustic-mapping's footprint pass, photon-splats).
COARSE_NEWTON_STEPS = 6


@dataclass
class LightView:
    """A light-space view: ``size`` x ``size`` texels per face, 1 face (projective) or 6 (cube atlas)."""

    sample: LightSample
    kind: int  # VIEW_PROJECTIVE or VIEW_CUBE
    size: int
    clips: np.ndarray  # (faces, 4, 4) clip_from_world per face
    forwards: np.ndarray  # (faces, 3) view axis per face
    unit_area: float  # texel area on the image plane at unit distance (orthographic: the texel's area)
    ortho: bool = False

    @property
    def faces(self) -> int:
        return 6 if self.kind == VIEW_CUBE else 1

    @property
    def atlas_size(self) -> tuple[int, int]:
        return (self.faces * self.size, self.size)

    @property
    def clip_from_world(self) -> np.ndarray:
        return self.clips[0]

    def caustic_map(self, texture) -> CausticMap:
        """The contract's CausticMap for a texture laid out in this view."""
        if self.kind == VIEW_CUBE:
            return CausticMap(texture, CAUSTIC_CUBE, None)
        return CausticMap(texture, CAUSTIC_PROJECTIVE, self.clips[0].astype("f4"))

    def bind(self, program) -> None:
        """Set this view as view 0 of caustic_light_space.glsl, and its light."""
        bind_views(program, [self])


def bind_views(program, views: list) -> None:
    """Set caustic_light_space.glsl's view arrays (VIEW_COUNT = len(views)) and the light of the first view."""
    count = len(views)
    kinds, orthos, sizes, areas = np.zeros(count, "i4"), np.zeros(count, "i4"), np.ones(count, "i4"), np.zeros(count, "f4")
    clips = np.tile(np.eye(4, dtype="f4"), (6 * count, 1, 1))
    forwards = np.zeros((6 * count, 3), "f4")
    for v, view in enumerate(views):
        if view is None:
            continue
        kinds[v], orthos[v], sizes[v], areas[v] = view.kind, int(view.ortho), view.size, view.unit_area
        clips[6 * v: 6 * v + view.faces] = view.clips
        forwards[6 * v: 6 * v + view.faces] = view.forwards
    # Drivers may shorten arrays to the entries a shader uses: write that many.
    for name, values in (("view_kind", kinds), ("view_ortho", orthos), ("view_size", sizes),
                         ("view_unit_area", areas), ("view_forward", forwards),
                         ("view_clip", np.ascontiguousarray(clips.transpose(0, 2, 1)))):
        if name in program:
            program[name].write(values[: max(program[name].array_length, 1)].tobytes())
    light = next(v for v in views if v is not None).sample
    set_uniform(program, "ls_light_type", int(light.type))
    set_uniform(program, "ls_light_position", np.asarray(light.position, "f4"))
    set_uniform(program, "ls_light_direction", np.asarray(light.direction, "f4"))
    set_uniform(program, "ls_light_intensity", np.asarray(light.intensity, "f4"))
    set_uniform(program, "ls_light_cone", np.asarray(light.cone_cos, "f4"))


def _scene_depth_range(sample: LightSample, scene) -> tuple[float, float]:
    """Near and far distances of the scene's bounding box from the light (along its direction if directional)."""
    low, high = scene.bounds()
    corners = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])
    radius = 0.5 * np.linalg.norm(high - low) + 1e-6
    if sample.type == LIGHT_DIRECTIONAL:
        d = (corners - sample.position) @ sample.direction
        return max(d.min() - 0.01 * radius, 1e-3 * radius), d.max() + 0.01 * radius
    far = np.linalg.norm(corners - sample.position, axis=1).max() * 1.01
    return 1e-3 * radius, far


def cube_view(sample: LightSample, size: int, scene) -> LightView:
    """The six-face atlas around a point light (Shah et al. III-F: an environment caustic map)."""
    near, far = _scene_depth_range(sample, scene)
    p = np.asarray(sample.position, dtype=np.float64)
    clips = np.stack([perspective_clip_from_view(90.0, 1.0, near, far) @ look_at_view_from_world(p, p + f, u)
                      for f, u in zip(CUBE_FORWARD, CUBE_UP)])
    return LightView(sample, VIEW_CUBE, int(size), clips, CUBE_FORWARD.copy(), (2.0 / size) ** 2)


def _ortho_view(sample: LightSample, scene, size: int, x0, x1, y0, y1) -> LightView:
    view = look_at_view_from_world(sample.position, sample.position + sample.direction, up_hint(sample.direction))
    near, far = _scene_depth_range(sample, scene)
    m = np.eye(4)
    m[0, 0], m[0, 3] = 2.0 / (x1 - x0), -(x1 + x0) / (x1 - x0)
    m[1, 1], m[1, 3] = 2.0 / (y1 - y0), -(y1 + y0) / (y1 - y0)
    m[2, 2], m[2, 3] = -2.0 / (far - near), -(far + near) / (far - near)
    area = (x1 - x0) * (y1 - y0) / size**2
    return LightView(sample, VIEW_PROJECTIVE, int(size), (m @ view)[None], sample.direction[None].copy(), area, True)


def _perspective_view(sample: LightSample, scene, size: int, axis, x0, x1, y0, y1) -> LightView:
    """Off-axis perspective view along ``axis`` over [x0, x1] x [y0, y1] on the plane at unit distance."""
    view = look_at_view_from_world(sample.position, sample.position + axis, up_hint(axis))
    near, far = _scene_depth_range(sample, scene)
    m = np.zeros((4, 4))
    m[0, 0], m[0, 2] = 2.0 / (x1 - x0), (x1 + x0) / (x1 - x0)
    m[1, 1], m[1, 2] = 2.0 / (y1 - y0), (y1 + y0) / (y1 - y0)
    m[2, 2], m[2, 3] = (far + near) / (near - far), 2.0 * far * near / (near - far)
    m[3, 2] = -1.0
    area = (x1 - x0) * (y1 - y0) / size**2
    return LightView(sample, VIEW_PROJECTIVE, int(size), (m @ view)[None], np.asarray(axis, float)[None], area)


def coarse_view(sample: LightSample, size: int, scene) -> LightView:
    """A view over the whole scene: orthographic box (directional), the atlas (point and spot lights).

    Spot lights get the atlas too, not their cone: refracted light leaves the
    cone (a prism bends a narrow beam by tens of degrees onto receivers the
    cone never sees), and this view must hold every landing point.
    """
    if sample.type != LIGHT_DIRECTIONAL:
        return cube_view(sample, size, scene)
    low, high = scene.bounds()
    corners = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])
    return fit_view(sample, corners, size, scene, margin_texels=1.0)


def fit_view(sample: LightSample, points: np.ndarray, size: int, scene, margin_texels: float = 2.0,
             weights: np.ndarray | None = None, trim: float = 0.0) -> LightView | None:
    """A square projective view fitted tightly around world ``points`` as the light sees them.

    Directional lights get an orthographic box, point and spot lights an
    off-axis perspective frustum aimed at the points; None when a point or spot
    light would need more than MAX_PROJECTIVE_HALF_ANGLE (use :func:`cube_view`).
    ``trim`` drops that fraction of the ``weights`` (flux) at each side of each
    axis (outliers that would spread the map thin); ``margin_texels`` pads it.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) == 0:
        return None
    direction = np.asarray(sample.direction, dtype=np.float64)
    if sample.type == LIGHT_DIRECTIONAL:
        axis = direction
    else:
        rays = points - sample.position
        rays /= np.maximum(np.linalg.norm(rays, axis=1, keepdims=True), 1e-30)
        axis = rays.mean(axis=0)
        if np.linalg.norm(axis) < 1e-6:
            return None
        axis /= np.linalg.norm(axis)
    view = look_at_view_from_world(sample.position, sample.position + axis, up_hint(axis))
    local = points @ view[:3, :3].T + view[:3, 3]
    if sample.type == LIGHT_DIRECTIONAL:
        xy = local[:, :2]
    else:
        depth = -local[:, 2]
        if np.any(depth <= 1e-9 * (1.0 + np.abs(local).max())):
            return None
        xy = local[:, :2] / depth[:, None]
    lo, hi = _trimmed_range(xy, weights, trim)
    centre, half = 0.5 * (lo + hi), 0.5 * float(np.max(hi - lo))
    half = max(half, 1e-6 * (1.0 + float(np.abs(centre).max()))) * size / max(size - 2.0 * margin_texels, 1.0)
    if sample.type == LIGHT_DIRECTIONAL:
        return _ortho_view(sample, scene, size, centre[0] - half, centre[0] + half, centre[1] - half, centre[1] + half)
    corner = np.abs(centre) + half
    if np.degrees(np.arctan(np.hypot(*corner))) > MAX_PROJECTIVE_HALF_ANGLE:
        return None
    return _perspective_view(sample, scene, size, axis, centre[0] - half, centre[0] + half,
                             centre[1] - half, centre[1] + half)


def _trimmed_range(xy: np.ndarray, weights: np.ndarray | None, trim: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis [lo, hi] keeping all but ``trim`` of the weight on each side."""
    if weights is None or trim <= 0.0:
        return xy.min(axis=0), xy.max(axis=0)
    lo, hi = np.empty(2), np.empty(2)
    total = float(weights.sum())
    for k in range(2):
        order = np.argsort(xy[:, k])
        cumulative = np.cumsum(weights[order]) / max(total, 1e-300)
        lo[k] = xy[order[np.searchsorted(cumulative, trim)], k]
        hi[k] = xy[order[min(np.searchsorted(cumulative, 1.0 - trim), len(order) - 1)], k]
    return lo, hi


def caster_points(objects) -> np.ndarray:
    """World vertices of the objects (the silhouettes a fitted view must hold)."""
    return np.concatenate([o.world_mesh().vertices.astype(np.float64) for o in objects]) if objects else np.zeros((0, 3))


@dataclass
class Photons:
    """Photons in an SSBO: ``count`` entries of {vec4 position (w = 1 landed), vec4 flux (W, RGB)}."""

    buffer: object
    count: int
    stats: dict = field(default_factory=dict)

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """(positions (n, 3), flux (n, 3)) of the photons that landed."""
        data = np.frombuffer(self.buffer.read(size=self.count * PHOTON_BYTES), dtype="f4").reshape(-1, 8)
        landed = data[:, 3] > 0.5
        return data[landed, :3].astype(np.float64), data[landed, 4:7].astype(np.float64)


def dispatch_photons(frame: Frame, program, size: tuple[int, int], count: int, initial: Photons | None,
                     stats: dict) -> Photons:
    """Run a photon compute shader over a ``size`` texel grid (8 x 8 groups) into a new buffer of ``count``
    photons (binding 0); binding 1 holds the ``initial`` photons (``has_initial``), or the new buffer."""
    buffer = frame.own(frame.gpu.ctx.buffer(reserve=count * PHOTON_BYTES))
    buffer.bind_to_storage_buffer(0)
    set_uniform(program, "has_initial", int(initial is not None))
    (initial.buffer if initial is not None else buffer).bind_to_storage_buffer(1)
    run_compute(program, (size[0] + 7) // 8, (size[1] + 7) // 8)
    frame.gpu.ctx.memory_barrier()
    return Photons(buffer, count, stats)


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
    faces (Wyman's back-face buffer). Receivers: the diffuse objects' front
    faces; caster fronts: every object (the rest occlude the grid).
    """

    reads = ()

    def __init__(self, views: str, channel: str, kinds=("diffuse",), faces: str = "front", coded=("glass", "mirror")):
        self.views, self.channel, self.kinds, self.faces, self.coded = views, channel, tuple(kinds), faces, tuple(coded)
        self.reads = (views,)
        self.writes = (Channel(channel, "rgba32f x2[light]", f"per light: (position+distance, normal+code) of {faces} "
                                                             f"faces of {'/'.join(self.kinds)} objects"),)

    def run(self, frame: Frame) -> None:
        frame.write(self.channel, [None if v is None else self.render(frame, v) for v in frame.read(self.views)])

    def render(self, frame: Frame, view: LightView):
        gpu = frame.gpu
        position, normal = frame.texture(view.atlas_size, "rgba32f"), frame.texture(view.atlas_size, "rgba32f")
        with frame.scratch(view.atlas_size, "depth") as depth:
            self._draw(frame, view, gpu.targets.framebuffer([position, normal], depth))
        return position, normal

    def _draw(self, frame: Frame, view: LightView, fbo) -> None:
        gpu, ctx = frame.gpu, frame.gpu.ctx
        fbo.use()
        back = self.faces == "back"
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=0.0 if back else 1.0)
        program = gpu.shaders.program("common/mesh_vertex.glsl", "passes/caustic_surface.frag",
                                      {"ALONG_DIRECTION": int(view.sample.type == LIGHT_DIRECTIONAL)})
        set_uniform(program, "origin", np.asarray(view.sample.position, "f4"))
        set_uniform(program, "direction", np.asarray(view.sample.direction, "f4"))
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = ">" if back else "<"
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
    first photon pass against ``coarse_view`` receivers; the flux-weighted
    ``trim`` fraction at each side is let go. Point lights fall back to the
    cube atlas when the landing points spread wider than one frustum.
    """

    def __init__(self, photons: str, size: int, margin_texels: float = 3.0, trim: float = 1e-3, point_map: str = "frustum"):
        self.photons, self.size, self.margin, self.trim = photons, int(size), margin_texels, trim
        self.point_map = point_map
        self.reads = ("light_samples", photons)
        self.writes = (Channel("caustic_views", "host[light]", "per light: LightView of the caustic map, or None"),)

    def run(self, frame: Frame) -> None:
        views = []
        for sample, photons in zip(frame.read("light_samples"), frame.read(self.photons)):
            view = None
            if photons is not None and sample.type == LIGHT_POINT and self.point_map == "cube":
                view = cube_view(sample, self.size, frame.scene)
            elif photons is not None:
                points, flux = photons.read()
                weights = flux.sum(axis=1)
                keep = weights > 0
                if keep.any():
                    view = fit_view(sample, points[keep], self.size, frame.scene, self.margin, weights[keep], self.trim)
                    if view is None:
                        view = cube_view(sample, self.size, frame.scene) if sample.type == LIGHT_POINT else \
                            coarse_view(sample, self.size, frame.scene)
            views.append(view)
        frame.write("caustic_views", views)


def float_atomics(frame: Frame) -> bool:
    """Whether this GL has imageAtomicAdd on r32f images (GL_NV_shader_atomic_float): where
    :class:`SplatPhotons`' 'auto' picks the compute splat (which itself needs only GL 4.3)."""
    return bool(frame.gpu.info.get("float_atomics"))


class SplatPhotons(Pass):
    """Photons into per-texel flux (Shah et al. III-C and III-F: additive point splats, Gaussian fall-off).

    ``mode`` 'compute' adds with integer atomics into 64-bit fixed-point sums
    (``passes/fixed_flux.py``: order-independent, so the same photons give the
    same bytes; core GL 4.3), 'points' draws additive Gaussian point sprites
    (blending in primitive order: deterministic too), 'auto' picks compute
    where GL_NV_shader_atomic_float exists (as before the compute splat went
    fixed-point), else points. Both use the normalised kernel of caustic_light_space.glsl
    (radius ``radius`` texels, sigma = radius / 2), so a photon deposits
    exactly its flux whichever path runs. Writes three r32f textures per light.
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
            out.append((self._compute if mode == "compute" else self._points)(frame, view, photons))
        frame.write("caustic_flux", out)

    def _compute(self, frame: Frame, view: LightView, photons: Photons) -> list:
        def dispatch(bind, bound: int) -> None:
            program = frame.gpu.shaders.compute("passes/caustic_splat.comp", {"FLUX_BOUND": bound})
            bind(program)
            view.bind(program)
            set_uniform(program, "photon_count", int(photons.count))
            set_uniform(program, "splat_radius", self.radius)
            photons.buffer.bind_to_storage_buffer(0)
            run_compute(program, (photons.count + 63) // 64)

        return splat_fixed_point(frame, view.atlas_size, dispatch)

    def _points(self, frame: Frame, view: LightView, photons: Photons) -> list:
        ctx = frame.gpu.ctx
        targets = [frame.zeroed(view.atlas_size, "r32f") for _ in range(3)]
        fbo = frame.gpu.targets.framebuffer(targets)
        fbo.use()
        fbo.viewport = (0, 0, *view.atlas_size)  # the targets came zeroed from the pool
        program = frame.gpu.shaders.program("passes/caustic_splat.vert", "passes/caustic_splat.frag")
        view.bind(program)
        set_uniform(program, "splat_radius", self.radius)
        vao = ctx.vertex_array(program, [(photons.buffer, "4f 4f", "in_position", "in_flux")])
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.enable(moderngl.BLEND | moderngl.PROGRAM_POINT_SIZE)
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        ctx.blend_equation = moderngl.FUNC_ADD
        vao.render(moderngl.POINTS, vertices=photons.count)
        ctx.disable(moderngl.BLEND | moderngl.PROGRAM_POINT_SIZE)
        ctx.blend_func = moderngl.DEFAULT_BLENDING
        vao.release()
        return targets


class ResolveCausticMaps(Pass):
    """Flux per texel into the ``caustic_maps`` contract: irradiance = flux / receiver area, alpha = distance.

    The receiver area of a texel is its solid angle times d^2 (or its
    perpendicular area) over the cosine between the receiver normal and the
    light, from the receivers' normal texture. The maps are new textures owned
    by the caller (:class:`CachedPasses` keeps them across frames).
    """

    def __init__(self, receivers: str = "receivers", views: str = "caustic_views"):
        self.receivers, self.views = receivers, views
        self.reads = ("caustic_flux", receivers, views)
        self.writes = (Channel("caustic_maps", "rgba32f + host[light]", "per light: CausticMap (irradiance W/m^2, receiver distance)"),)

    def run(self, frame: Frame) -> None:
        ctx = frame.gpu.ctx
        program = frame.gpu.shaders.compute("passes/caustic_resolve.comp")
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


def material_state_key(scene) -> tuple:
    """What caustic maps depend on beyond shadow maps: every object's material."""
    return tuple(state_key(o.material) for o in scene.objects)


class CachedPasses(Pass):
    """Run ``passes`` only when lights, objects, materials or ``key`` change; reuse their outputs otherwise.

    The graph caches the ``keep`` channels (passes/graph.py, :meth:`Pass.cache_key`); whatever else
    the inner passes wrote is given back when they finish.
    """

    def __init__(self, tag: str, key, passes: list, keep: tuple[str, ...] = ("caustic_maps",)):
        self.tag, self.key, self.passes, self.keep = tag, key, list(passes), tuple(keep)
        inner = {c.name for p in self.passes for c in p.writes}
        self.reads = tuple(dict.fromkeys(("light_samples", *(n for p in self.passes for n in p.reads if n not in inner))))
        self.writes = tuple(c for p in self.passes for c in p.writes if c.name in self.keep)
        self.rebuilt = 0  # how many times the inner passes ran (tests)

    @property
    def label(self) -> str:
        return f"{type(self).__name__}({self.tag})"

    def cache_key(self, frame: Frame):
        return self.key, scene_state_key(frame.scene), material_state_key(frame.scene)

    def run(self, frame: Frame) -> None:
        before = set(frame.channels)
        run_passes(self.passes, frame, keep=before | set(self.keep))
        for name in set(frame.channels) - before - set(self.keep):
            del frame.channels[name]  # given back by the inner graph
        self.rebuilt += 1
