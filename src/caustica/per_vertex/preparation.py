"""The CPU side of steps 1-3 of per-vertex reflection and refraction (Kakimoto et al.) for one mirror or lens: its
vertices' twice-refracted lines through a lens (4.5), the view volume of a set of its vertices with the up vector
on a principal direction (3.2, 3.3, 4.3), the adaptive refinement of a mirror's mesh (ours, 4.1), the texture
coordinates of every vertex's hit in its patch's map (3.4, 4.2), and where a point falls on the eye's image.
techniques/per_vertex.py's prepare_reflector runs them on each reflector before the passes.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..cache import LruCache
from ..raytrace.optics import normalize
from .patches import Patch, unique_indices
from .rays import double_refraction, reflection_rays, trace_lines
from .refine import Traced, refine
from .viewpoint import Lines, ViewVolume, fit_view_volume, hidden, principal_directions, widen_view_volume

if TYPE_CHECKING:
    from ..techniques.per_vertex import PerVertexParams

_LENS_CACHE = LruCache(32)  # refraction vectors in eye space while a lens is fixed to the eye
REFINE_MIN_PIXELS = 1.0  # mirror edges this short on the screen are not split
REFINE_TEST_PIXELS = 4.0  # shorter edges are split only where their ends' rays hit different surfaces
REFINE_BUDGET = 8  # a refined mirror has at most this many times its mesh's vertices


@dataclass
class Reflector:
    """The per-vertex work for one mirror or lens: rays, exact hits, patches, texture coordinates."""

    index: int  # in scene.objects
    lens: bool
    vertex_ids: np.ndarray  # (m,) ray-issuing vertices of the object's mesh
    faces: np.ndarray  # (f, 3) faces to draw, indexing vertex_ids
    channels: list[Lines]  # per colour channel (one for mirrors), per ray-issuing vertex
    weight: np.ndarray  # (m, 3) mirror colour, or lens exit transmittance per channel
    valid: np.ndarray  # (m,) the vertex has a usable ray
    points: np.ndarray  # (m, 3) world positions of the ray-issuing vertices
    local_points: np.ndarray  # (m, 3) their object-space positions and normals (drawn)
    local_normals: np.ndarray
    patches: list[Patch] = field(default_factory=list)
    uv: list[np.ndarray] = field(default_factory=list)  # per patch: (3, k, 2)
    zoom: list[np.ndarray] = field(default_factory=list)  # per patch: (k,) bool


def reflector_kind(obj, params: PerVertexParams) -> str | None:
    """'mirror', 'lens' or None (not rendered per vertex)."""
    if obj.material.kind == "mirror":
        return "mirror"
    if obj.material.kind == "glass" and params.lenses:
        return "lens"
    return None


def refine_mirror(reflector: Reflector, normals, traced: Traced, eye, camera, ray_scene, map_scene, bounds,
                  params: PerVertexParams) -> None:
    """Adaptive subdivision of a mirror's mesh (refine.py), judged in each patch's map; each patch keeps
    the pieces of its faces and its viewpoint, its frustum widened to hold their lines."""

    def trace(attributes) -> Traced:
        lines, hits = trace_lines(ray_scene, *reflection_rays(eye, attributes["points"], normalize(attributes["normals"])))
        return Traced(lines, hits.object_index, hits.normal)

    patch_of = np.zeros(len(reflector.faces), np.int64)
    for k, patch in enumerate(reflector.patches):
        patch_of[patch.rows] = k
    volumes = [patch.volume for patch in reflector.patches]

    def per_patch(measure):
        """``measure(volume, lines)`` of each line in the map of its face's patch."""
        def apply(lines, faces):
            groups, out = patch_of[faces], None
            for k in unique_indices(groups):
                mine = groups == k
                part = measure(reflector.patches[k].volume, lines.subset(mine))
                out = np.zeros((len(faces), *part.shape[1:]), part.dtype) if out is None else out
                out[mine] = part
            return out
        return apply

    attributes = {"points": reflector.points, "normals": normals, "local_points": reflector.local_points,
                  "local_normals": reflector.local_normals}
    refined = refine(reflector.faces, attributes, traced, trace, lambda a: screen_pixels(camera, a["points"]),
                     per_patch(lambda volume, lines: volume.texture_coordinates(lines)[0]), params.refine,
                     REFINE_MIN_PIXELS, REFINE_TEST_PIXELS, params.refine_levels, REFINE_BUDGET * len(reflector.points),
                     lambda lines, faces: hidden(volumes, patch_of[faces], lines, map_scene))
    if refined.levels == 0:
        return
    count = len(refined.traced.objects)
    reflector.faces, reflector.channels = refined.faces, [refined.traced.lines]
    reflector.points = refined.attributes["points"]
    reflector.local_points, reflector.local_normals = refined.attributes["local_points"], refined.attributes["local_normals"]
    reflector.weight = np.resize(reflector.weight, (count, 3))
    reflector.valid = np.ones(count, bool)
    patch_of = patch_of[refined.parents]
    patches = []
    for k, patch in enumerate(reflector.patches):
        rows = np.nonzero(patch_of == k)[0]
        vertices = unique_indices(refined.faces[rows])
        lines, volume = reflector.channels[0].subset(vertices), patch.volume
        uv, zoom, valid = volume.texture_coordinates(lines)
        view = volume.view_from_world
        depth = -(lines.hit_points[lines.finite & ~zoom] @ view[2, :3] + view[2, 3])
        if not (valid.all() and np.all((uv > 0.0) & (uv < 1.0)) and np.all(depth > volume.near)):  # a new line
            volume = widen_view_volume(volume, lines, reflector.points[vertices], bounds)  # leaves the frustum
        patches.append(Patch(refined.faces[rows], vertices, volume, rows))
    reflector.patches = patches


def lens_lines(scene, index, obj, eye, p, n, ray_scene, params, eye_from_world):
    """Twice-refracted lines per channel (4.5), from the cache while the lens is fixed to the eye."""
    ior_rgb = np.asarray(params.ior_rgb if params.ior_rgb is not None else obj.material.ior_rgb, dtype=np.float64)
    key = None
    if params.cache and eye_from_world is not None:
        relative = np.round(eye_from_world @ obj.world_from_object(), 9)
        key = (obj.mesh.content_hash(), relative.tobytes(), ior_rgb.tobytes(), params.max_interfaces)
    cached = _LENS_CACHE.get(key) if key is not None else None
    if cached is None:
        refracted = {}
        for ior in np.unique(ior_rgb):
            refracted[ior] = double_refraction(ray_scene, index, eye, p, n, float(ior), params.max_interfaces)
        if key is not None:
            # Eye space, so that the cache holds while eye and lens move together.
            rot, shift = eye_from_world[:3, :3], eye_from_world[:3, 3]
            _LENS_CACHE[key] = {ior: (r.origins @ rot.T + shift, r.directions @ rot.T, r.transmittance,
                                      r.path_length, r.valid) for ior, r in refracted.items()}
        rays = {ior: (r.origins, r.directions, r.transmittance, r.path_length, r.valid) for ior, r in refracted.items()}
    else:
        world_from_eye = np.linalg.inv(eye_from_world)
        rot, shift = world_from_eye[:3, :3], world_from_eye[:3, 3]
        rays = {ior: (o @ rot.T + shift, d @ rot.T, t, length, ok) for ior, (o, d, t, length, ok) in cached.items()}
    # Step 3.1 per distinct IOR: the exact hits of the exit rays.
    traced = {ior: trace_lines(ray_scene, o, d)[0] for ior, (o, d, *_rest) in rays.items()}
    channels = [traced[ior] for ior in ior_rgb]
    sigma = obj.material.absorption_coefficient
    weight = np.stack([rays[ior][2] * np.exp(-sigma[c] * rays[ior][3]) for c, ior in enumerate(ior_rgb)], axis=1)
    valid = np.logical_and.reduce([rays[ior][4] for ior in ior_rgb])
    return channels, np.where(valid[:, None], weight, 0.0), valid


def volume_fit(reflector: Reflector, scene, p, n, eye, camera_up, params) -> Callable[[np.ndarray], ViewVolume]:
    """``fit(vertices)``: the view volume of those of the reflector's vertices (3.2, 3.3, 4.3), from
    its lines at the time of the call (a refined mirror has more)."""
    bounds = scene.bounds()
    camera_up = np.asarray(camera_up, dtype=np.float64)
    principal = _principal_axes(p, n, eye, camera_up)
    up, extra = {"principal": (principal[0], ()), "camera": (camera_up, ()),
                 "auto": (principal[0], (camera_up,))}[params.up]  # the other principal direction: the same box turned

    def fit(vertices: np.ndarray) -> ViewVolume:
        green = reflector.channels[min(1, len(reflector.channels) - 1)]
        distinct = [reflector.channels[0]] if len(reflector.channels) == 1 else reflector.channels
        vertices = vertices[reflector.valid[vertices]]
        if len(vertices) == 0:
            vertices = np.arange(len(reflector.points))
        lines = [ch.subset(vertices) for ch in distinct]
        merged = Lines(*(np.concatenate([getattr(x, name) for x in lines]) for name in ("origins", "directions", "distance")))
        return fit_view_volume(merged, reflector.points[vertices], bounds, up, extra,
                               viewpoint_lines=green.subset(vertices))

    return fit


UMBILIC = 1e-3  # principal curvatures this close (times the mirror's size) leave the principal directions undefined


def _principal_axes(p: np.ndarray, n: np.ndarray, eye: np.ndarray, camera_up: np.ndarray) -> np.ndarray:
    """The mirror's principal directions (4.3), or, where they are undefined (a sphere's or a plane's curvature
    is the same in every direction), the camera's up and its perpendicular: the least-squares fit's
    eigenvectors are then its round-off, and a frustum turned by them changed with the scene's unit."""
    if len(p) < 3:
        return np.zeros((2, 3))
    directions, curvature = principal_directions(p, n, eye - p.mean(axis=0))
    size = float(np.linalg.norm(np.ptp(p, axis=0)))
    if abs(float(curvature[1] - curvature[0])) * size > UMBILIC:
        return directions
    return np.stack([camera_up, np.cross(camera_up, normalize(n.mean(axis=0)))])


def texture_coordinates(reflector: Reflector) -> None:
    """Each patch's texture coordinates of its vertices' exact hits (3.4), and its zooming-region flags (4.2)."""
    for patch in reflector.patches:
        coords = [patch.volume.texture_coordinates(ch.subset(patch.vertices)) for ch in reflector.channels]
        uv = np.stack([c[0] for c in coords])
        reflector.uv.append(uv if len(uv) == 3 else np.repeat(uv, 3, axis=0))
        reflector.zoom.append(coords[min(1, len(coords) - 1)][1])


def screen_pixels(camera, points: np.ndarray, clamp: bool = False) -> np.ndarray:
    """(n, 2) pixel positions of world ``points`` on ``camera``'s image (``clamp``: to its borders); nan
    for a point behind the eye."""
    clip = np.c_[points, np.ones(len(points))] @ np.asarray(camera.clip_from_world(), np.float64).T
    w = clip[:, 3:4]
    ndc = clip[:, :2] / np.where(w > 1e-9, w, np.nan)
    return (np.clip(ndc, -1.0, 1.0) if clamp else ndc) * 0.5 * np.asarray(camera.size, np.float64) + \
        0.5 * np.asarray(camera.size, np.float64)
