"""Light-space views of the caustic passes: what the light sees, fitted tightly (Shah et al. III-B, III-F).

Shah et al., "Caustics Mapping: An Image-space Technique for Real-time
Caustics" (TVCG 2007), render receivers and refractors *from the light* (III-B)
and splat photons into a light-space caustic map (III-F); Wyman's photon
splats do the same. This module holds the views those maps live in:

- :class:`LightView`: a light-space view, projective (perspective or
  orthographic, any ``clip_from_world``) or a six-face cube atlas (6N x N, the
  layout of ``passes/shading/shadows.py``), with its texels' area at unit distance (the shaders'
  ``texel_measure``: solid angle or perpendicular area) and ``bind`` /
  :func:`bind_views` for ``shaders/passes/caustics/caustic_light_space.glsl``.
- Fitting (III-F, "view frustum limitation"): :func:`fit_view` fits a view
  tightly around world points as seen from the light (the casters' vertices,
  :func:`caster_points`, for the photon grid of III-B; the photons' landing
  points for the caustic map, trimmed of a tiny flux fraction),
  :func:`coarse_view` covers the whole scene, :func:`cube_view` is the
  omnidirectional atlas for point lights (III-F: an environment caustic map).

The passes that fit these views each frame are in ``passes/caustics/light_space.py``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...gpu.meshes import set_uniform
from ...lighting.samples import CUBE_FORWARD, CUBE_UP, LightSample
from ...scene.transform import look_at_view_from_world, perspective_clip_from_view, up_hint
from ..shading.shadows import LIGHT_DIRECTIONAL
from .maps import CAUSTIC_CUBE, CAUSTIC_PROJECTIVE, CausticMap

VIEW_PROJECTIVE, VIEW_CUBE = 0, 1
MAX_PROJECTIVE_HALF_ANGLE = 60.0  # degrees: wider footprints of a point light go to the cube atlas


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

