"""Virtual viewpoint and view volume of per-vertex reflection (Kakimoto et al., 3.2-3.4, 4.2, 4.3).

Every ray-issuing vertex contributes one line: where the reflected (or
twice-refracted) ray leaves the surface, its direction, and the distance to
its exact hit (inf for a miss). From these lines:

- 3.2: the virtual viewpoint E is the point with the least summed squared
  distance to all lines (closed form: solve sum(I - d d^T) E = sum(I - d d^T) o).
- 3.3: the view direction is the mean line direction; the near plane sits just
  past the farthest reflector vertex (clamped in front of the nearest hit), the
  far plane past the scene; left/right/bottom/top hold every line segment
  between the near and far planes (an off-axis frustum, stored as tangents so
  that it does not depend on the near distance); a ray that escapes to the
  environment contributes its direction.
- 3.4: a vertex's texture coordinates are the projection Q of its exact hit
  point P (or of its direction, for a miss) into that frustum, in [0, 1]^2.
- 4.2: hits between the reflector and E (the zooming region of a concave
  mirror or a convex lens) are seen from E looking back at the reflector.
  Viewing along -f with all view axes negated (a point reflection) projects
  such a point to the same Q as its line's forward part, so both maps share
  the texture coordinates; that reversed map keeps the point farthest from E
  (nearest to the reflector) through a projection with a negated depth row,
  the reversed depth test of the paper's fig. 8(b) and section 7.
- 4.3: the frustum's up vector lies on a principal curvature direction of the
  reflector ('principal'), the eye camera's up ('camera'), or whichever of the
  two gives the smaller frustum ('auto').
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..raytrace.optics import normalize
from ..scene.transform import look_at_view_from_world

UP_MODES = ("principal", "camera", "auto")
MARGIN = 0.01  # frustum margin on each side, as a fraction of its extent


@dataclass
class Lines:
    """Per-vertex reflected (or refracted) rays: origin, unit direction, distance to the exact hit (inf: miss)."""

    origins: np.ndarray  # (n, 3)
    directions: np.ndarray  # (n, 3)
    distance: np.ndarray  # (n,)

    @property
    def finite(self) -> np.ndarray:
        return np.isfinite(self.distance)

    @property
    def hit_points(self) -> np.ndarray:
        """(n, 3) exact hit points (the origin for misses)."""
        return self.origins + np.where(self.finite, self.distance, 0.0)[:, None] * self.directions

    def subset(self, index) -> "Lines":
        return Lines(self.origins[index], self.directions[index], self.distance[index])


def closest_point_to_lines(origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """The point with the least summed squared distance to the lines o_i + s d_i (section 3.2)."""
    d = normalize(np.asarray(directions, dtype=np.float64))
    o = np.asarray(origins, dtype=np.float64)
    # The distance^2 from p to a line is |(I - d d^T)(p - o)|^2; its gradient vanishes where
    # sum(I - d d^T) p = sum(I - d d^T) o.
    a = len(d) * np.eye(3) - d.T @ d
    b = o.sum(axis=0) - d.T @ np.einsum("ij,ij->i", d, o)
    return np.linalg.lstsq(a, b, rcond=None)[0]


def viewpoint_parallax(lines: Lines) -> float:
    """The mean angle, in degrees, between each line and the direction from the lines' least-squares viewpoint E
    (3.2) to its exact hit (0 for a line that escapes: any viewpoint sees the environment along it): how far from
    E's view the reflection is, which a map rendered from E warps back only at the vertices (exact at every
    vertex, 3.4; occlusion and the texture between them come from E, section 6). 0 where the lines meet in one
    point (a flat mirror); largest where they pass apart (cylinders and saddles, whose two principal curvatures
    differ); 0 for no lines."""
    finite = lines.finite
    if not finite.any():
        return 0.0
    position = closest_point_to_lines(lines.origins, lines.directions)
    sight = normalize(lines.hit_points[finite] - position)
    cosine = np.clip(np.einsum("ij,ij->i", sight, lines.directions[finite]), -1.0, 1.0)
    return float(np.degrees(np.arccos(cosine)).sum() / len(finite))


def frustum_clip_from_view(left: float, right: float, bottom: float, top: float, near: float, far: float) -> np.ndarray:
    """General (off-axis) OpenGL perspective projection, glFrustum's matrix: the near-plane
    rectangle [left, right] x [bottom, top] at distance ``near``."""
    m = np.zeros((4, 4))
    m[0, 0] = 2.0 * near / (right - left)
    m[0, 2] = (right + left) / (right - left)
    m[1, 1] = 2.0 * near / (top - bottom)
    m[1, 2] = (top + bottom) / (top - bottom)
    m[2, 2] = (far + near) / (near - far)
    m[2, 3] = 2.0 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


# A point reflection of view space: the reversed map looks along -f with x and y negated too.
_POINT_REFLECTION = np.diag([-1.0, -1.0, -1.0, 1.0])


@dataclass
class ViewVolume:
    """The first-pass camera of one reflector (patch): viewpoint, off-axis frustum, near/far planes."""

    position: np.ndarray
    view_from_world: np.ndarray
    bounds: np.ndarray  # (left, right, bottom, top) as tangents (near-plane coordinates / near)
    near: float
    far: float
    zoom_near: float | None = None  # reversed map (zooming region) planes; None when no hit lies there
    zoom_far: float | None = None

    @property
    def fov_degrees(self) -> tuple[float, float]:
        """Horizontal and vertical field of view of the frustum."""
        left, right, bottom, top = np.arctan(self.bounds)
        return float(np.degrees(right - left)), float(np.degrees(top - bottom))

    @property
    def has_zoom(self) -> bool:
        return self.zoom_near is not None

    def clip_from_world(self, reverse: bool = False) -> np.ndarray:
        """Forward map, or (``reverse``) the zooming-region map with its reversed depth order."""
        left, right, bottom, top = self.bounds
        if not reverse:
            return frustum_clip_from_view(left * self.near, right * self.near, bottom * self.near,
                                          top * self.near, self.near, self.far) @ self.view_from_world
        n, f = self.zoom_near, self.zoom_far
        clip = frustum_clip_from_view(left * n, right * n, bottom * n, top * n, n, f)
        clip[2] = -clip[2]  # reversed depth: the point farthest from E wins a '<' test
        return clip @ _POINT_REFLECTION @ self.view_from_world

    def texture_coordinates(self, lines: Lines) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(uv (n,2), zoom (n,) bool, valid (n,) bool): Q of each exact hit (3.4), the direction for misses."""
        finite = lines.finite
        view = _to_view(self.view_from_world, lines.hit_points, lines.directions, finite)
        depth = -view[:, 2]
        valid = np.abs(depth) > 1e-12
        q = view[:, :2] / np.where(valid, depth, 1.0)[:, None]
        left, right, bottom, top = self.bounds
        uv = np.stack([(q[:, 0] - left) / (right - left), (q[:, 1] - bottom) / (top - bottom)], axis=1)
        zoom = finite & (depth < 0)
        valid &= finite | (depth > 0)  # a miss must point forward
        return uv, zoom, valid


def hidden(volumes: list[ViewVolume], which: np.ndarray, lines: Lines, ray_scene) -> np.ndarray:
    """(n,) bool: the forward map of ``volumes[which[i]]`` does not show line i's exact hit, another
    surface lies before it as seen from the viewpoint (the occlusion inconsistency of section 6, fig. 16).
    ``ray_scene``: the maps' scene (without the reflector). Misses and zooming-region hits: False."""
    position = np.array([v.position for v in volumes])[which]
    forward = -np.array([v.view_from_world[2, :3] for v in volumes])[which]
    near = np.array([v.near for v in volumes])[which]
    offset = lines.hit_points - position
    distance = np.linalg.norm(offset, axis=1)
    towards = offset / np.maximum(distance, 1e-300)[:, None]
    cosine = np.einsum("ij,ij->i", towards, forward)
    test = np.nonzero(lines.finite & (cosine > 1e-6))[0]
    out = np.zeros(len(distance), bool)
    if len(test):
        start = near[test] / cosine[test]  # the map sees nothing before its near plane
        hits = ray_scene.intersect(position[test] + start[:, None] * towards[test], towards[test])
        out[test] = hits.hit & (start + hits.t < distance[test] * (1.0 - 1e-4) - 1e-6)
    return out


def _to_view(view_from_world, points, directions, finite) -> np.ndarray:
    """View-space coordinates of hit points, or of directions (w = 0) where ``finite`` is False."""
    rotated = directions @ view_from_world[:3, :3].T
    placed = points @ view_from_world[:3, :3].T + view_from_world[:3, 3]
    return np.where(finite[:, None], placed, rotated)


def principal_directions(points: np.ndarray, normals: np.ndarray, towards: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal curvature directions of a surface patch and their curvatures, from its vertices.

    The shape operator is fitted by least squares in the tangent plane of the mean normal
    (oriented to ``towards``): tangential normal components g ~ -S x for tangential
    offsets x. Returns (directions (2, 3) world, curvatures (2,)), the most concave first.
    """
    n0 = normalize(normals.mean(axis=0))
    if np.dot(n0, towards) < 0:
        n0, normals = -n0, -normals
    t1 = normalize(np.cross(n0, [1.0, 0.0, 0.0] if abs(n0[0]) < 0.9 else [0.0, 1.0, 0.0]))
    t2 = np.cross(n0, t1)
    frame = np.stack([t1, t2])
    x = (points - points.mean(axis=0)) @ frame.T
    g = normals @ frame.T
    s = -np.linalg.lstsq(np.c_[x, np.ones(len(x))], g, rcond=None)[0][:2]
    curvature, vectors = np.linalg.eigh(0.5 * (s + s.T))  # ascending: the most concave first
    return vectors.T @ frame, curvature


def fit_view_volume(lines: Lines, reflector_points: np.ndarray, scene_bounds: np.ndarray, up: np.ndarray,
                    up_candidates: tuple = (), viewpoint_lines: Lines | None = None) -> ViewVolume:
    """Virtual viewpoint (3.2) and view volume (3.3, 4.2) for ``lines``.

    ``viewpoint_lines`` (default ``lines``) choose the viewpoint and view direction (the lens
    uses the green channel's); the frustum holds every line. ``up_candidates``: further up
    vectors; the one giving the smallest frustum wins.
    """
    chosen = viewpoint_lines or lines
    position = closest_point_to_lines(chosen.origins, chosen.directions)
    forward = normalize(chosen.directions.mean(axis=0))
    if np.linalg.norm(forward) < 1e-9:
        forward = chosen.directions[0]
    best = None
    for candidate in (up, *up_candidates):
        volume = _frustum(lines, reflector_points, scene_bounds, position, forward, candidate)
        area = (volume.bounds[1] - volume.bounds[0]) * (volume.bounds[3] - volume.bounds[2])
        if best is None or area < best[0]:
            best = (area, volume)
    return best[1]


def widen_view_volume(volume: ViewVolume, lines: Lines, reflector_points: np.ndarray,
                      scene_bounds: np.ndarray) -> ViewVolume:
    """``volume``'s viewpoint and axes with a frustum and planes that hold ``lines`` (3.3): for vertices
    added to a patch whose viewpoint stays."""
    view = volume.view_from_world
    return _frustum(lines, reflector_points, scene_bounds, volume.position, -view[2, :3], view[1, :3])


def _frustum(lines: Lines, reflector_points, scene_bounds, position, forward, up) -> ViewVolume:
    """The view volume from ``position`` along ``forward`` with ``up`` (projected off ``forward``)."""
    scale = float(np.linalg.norm(np.ptp(np.vstack([scene_bounds, reflector_points, position[None]]), axis=0))) + 1e-9
    up = np.asarray(up, dtype=np.float64)
    up = up - np.dot(up, forward) * forward
    if np.linalg.norm(up) < 1e-6:
        up = np.cross(forward, [1.0, 0.0, 0.0] if abs(forward[0]) < 0.9 else [0.0, 0.0, 1.0])
    view = look_at_view_from_world(position, position + forward, normalize(up))
    finite = lines.finite
    hit_depth = -_to_view(view, lines.hit_points, lines.directions, np.ones(len(finite), bool))[:, 2]
    forward_lines = ~finite | (hit_depth > 0)
    zoom_lines = finite & (hit_depth <= 0)
    # Near plane just past the reflector, in front of the nearest forward hit; far plane past the scene.
    reflector_depth = -(reflector_points @ view[:3, :3].T + view[:3, 3])[:, 2]
    corners = np.array(np.meshgrid(*scene_bounds.T)).reshape(3, -1).T
    far = max(float((-(corners @ view[:3, :3].T + view[:3, 3])[:, 2]).max()), 1e-3 * scale) * 1.01
    near = reflector_depth.max() + 1e-4 * scale
    forward_hits = hit_depth[forward_lines & finite]
    if len(forward_hits):
        near = np.clip(near, 0.25 * forward_hits.min(), 0.9 * forward_hits.min())
    near = float(min(max(near, 1e-4 * scale), 0.5 * far))
    zoom_near = zoom_far = None
    if zoom_lines.any():
        zoom_depth = -hit_depth[zoom_lines]
        zoom_near = float(max(0.9 * zoom_depth.min(), 1e-4 * scale))
        zoom_far = float(max(zoom_depth.max() * 1.01, zoom_near * 1.01) + 1e-4 * scale)
    # Left/right/bottom/top: every segment's part between the planes (3.3), every Q.
    q = [_segment_tangents(view, lines.subset(forward_lines), near, far, 1.0)]
    if zoom_lines.any():
        q.append(_segment_tangents(view, lines.subset(zoom_lines), zoom_near, zoom_far, -1.0))
    q = np.concatenate(q)
    q = q[np.all(np.isfinite(q), axis=1)]
    if len(q) == 0:
        q = np.array([[-1.0, -1.0], [1.0, 1.0]])
    lo, hi = q.min(axis=0), q.max(axis=0)
    pad = MARGIN * np.maximum(hi - lo, 1e-6) + 1e-6
    bounds = np.array([lo[0] - pad[0], hi[0] + pad[0], lo[1] - pad[1], hi[1] + pad[1]])
    return ViewVolume(position, view, bounds, near, far, zoom_near, zoom_far)


def _segment_tangents(view, lines: Lines, near: float, far: float, sign: float) -> np.ndarray:
    """Tangent-plane coordinates (x/depth, y/depth) of the ends of each segment's part with
    sign * depth in [near, far], plus each exact hit (or miss direction)."""
    if len(lines.distance) == 0:
        return np.zeros((0, 2))
    o = lines.origins @ view[:3, :3].T + view[:3, 3]
    d = lines.directions @ view[:3, :3].T
    depth0, rate = -sign * o[:, 2], -sign * d[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        s_near, s_far = (near - depth0) / rate, (far - depth0) / rate
    s_in = np.where(rate > 0, s_near, s_far)
    s_out = np.where(rate > 0, s_far, s_near)
    flat = np.abs(rate) < 1e-12
    inside_flat = (depth0 >= near) & (depth0 <= far)
    s_in = np.where(flat, np.where(inside_flat, 0.0, np.inf), np.maximum(s_in, 0.0))
    s_out = np.where(flat, np.where(inside_flat, lines.distance, -np.inf), np.minimum(s_out, lines.distance))
    # Misses contribute their direction only: near E their segments would spread without bound.
    keep = (s_in <= s_out) & np.isfinite(s_in) & np.isfinite(s_out) & lines.finite
    ends = [o[keep] + s[keep, None] * d[keep] for s in (s_in, s_out)]
    # The exact hits themselves (and the miss directions at infinity).
    finite = lines.finite
    target = np.where(finite[:, None], o + np.where(finite, lines.distance, 0.0)[:, None] * d, d)
    ends.append(target[(-sign * target[:, 2]) > 0])
    points = np.concatenate(ends)
    return points[:, :2] / (-points[:, 2:3])
