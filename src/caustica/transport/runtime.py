"""Run time of the light transport table (Iwasaki et al., section 5): refracted rays and caustic photons.

Per glass object and light sample (``passes/shading/shadows.py``: directional, point,
spot; a line light is N point samples):

1. Lookup (5.1): the light's incident direction at every vertex, in the
   object's frame (the object moves rigidly: rotation, translation, uniform
   scale), in the vertex's tangent frame gives (elevation, azimuth); the four
   nearest sampled directions are the corners of its cell in the
   (ring, azimuth) grid; exit position and transmittance are interpolated
   bilinearly, the exit direction by spherical linear interpolation (the slerp
   of the rotations that carry one direction to the next, along azimuth then
   elevation). Self-occluded samples (concave objects) weigh 0.
2. Illumination volumes (5.1, eq. 2): each lit triangle of the object
   (geometric normal towards the light) receives the flux E S, E the
   irradiance perpendicular to the light at its centroid and S its area
   projected along the light; the three refracted rays of its vertices sweep an
   illumination volume that carries E S times the mean transmittance (and
   Beer-Lambert absorption over |x_out - P_i|) to where it meets a receiver,
   so that the caustic intensity there is E S F_t / S_p (eq. 2).
3. Accumulation on the receivers (the caustic-map path): the vertex rays are
   intersected with the diffuse receivers exactly (Embree). Where a volume's
   three rays land on one plane, the landed triangle *is* the intersection
   S_p: photons at the centroids of an m x m subdivision of it carry E S F_t /
   m^2 each (uniform intensity over S_p, eq. 2). Other volumes (over an edge,
   partly missing, on curved receivers) send their m^2 sub-rays (barycentric
   blends of the vertex rays) to the receivers individually. m^2 is the
   volume's share of ``photon_budget``: half shared by S_p (a uniform cover
   of the receivers), half by flux (bright volumes get several photons). The shared splat + resolve passes
   (``passes/caustics/light_space.py``) turn the photons into caustic maps.

Traced exit rays (ours, ``exit_rays="traced"``; :func:`traced_exit_rays`): the vertex rays are traced with
Embree through the object for the light's own directions (the precompute's trace, ``trace_samples``) instead of
looked up, and a volume whose three rays part (:func:`parting`: their exit points spread over more than
PARTING_SPREAD of its edges, or their directions over 15 degrees) sends its m^2 sub-rays from their points
inside the face, each traced, instead of blends of the vertex rays. Why: on a scanned bunny the exit rays of a
vertex change branch (through an ear into the body or past it, out of a hole, reflected totally or not) between
the table's neighbouring directions, so a lookup blended between them can be far from the ray traced for the
light's own direction, and many of the bunny's lit volumes part (docs/benchmarks-archive.md, "the bunny's caustic
through the transport table"). The cost
moves from the precompute to every light or object change (the vertex rays and the parting volumes' sub-rays).

Limits: only the refracted branch (Fresnel-reflected light is not splatted,
as in the paper); light blocked between the light and the glass by other
objects, and light refracted by two glass objects in a row, are ignored; the
absorption length is the straight distance from P_i to x_out (exact for two
interfaces, short for internal reflections). Ours: large flat faces are split
for the table (:func:`table_mesh`), and dispersive glass has a table per
channel's IOR (:func:`object_exit_rays`).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..cache import LruCache, atomic_write_bytes, cache_dir
from ..raytrace.embree_scene import RayScene
from ..raytrace.optics import dot, normalize
from ..scene.codes import LIGHT_DIRECTIONAL, LIGHT_SPOT
from ..scene.mesh import Mesh, split_at_midpoints
from .compress import TransportTableError, dequantize, load_table, quantize, table_bytes
from .precompute import (DEFAULT_DIRECTIONS, DEFAULT_MAX_DEPTH, TABLE_VERSION, TransportTable, glass_scene,
                         precompute_table, tangent_frames, trace_samples)

MAX_SUBDIVISION = 256
_TABLES: LruCache = LruCache(8)  # the tables most recently used
TABLE_EDGE = 1.0 / 64  # flat faces are split until their edges are at most this fraction of the mesh's diagonal
TABLE_VERTICES = 1 << 17  # ... while the mesh stays under this many vertices
_TABLE_MESHES: LruCache = LruCache(16)


def table_mesh(mesh: Mesh) -> Mesh:
    """The mesh a caustics table is made for: ``mesh`` itself, or, where it has large flat faces (a box, a
    prism, low-poly glass), a copy with those faces split at their midpoints until their edges are at most
    TABLE_EDGE of the diagonal. The paper tabulates finely tessellated objects (4): a flat face's vertices lie
    on its edges, where entering light meets the next face at once, so a prism's own table holds almost no
    valid sample. Faces whose vertex normals differ (a smooth surface) are kept: splitting them adds no shape."""
    key = mesh.geometry_hash()
    found = _TABLE_MESHES.get(key)
    if found is None:
        found = _TABLE_MESHES[key] = _split_flat_faces(mesh)
    return found


def _split_flat_faces(mesh: Mesh) -> Mesh:
    vertices, normals = mesh.vertices.astype(np.float64), normalize(mesh.normals.astype(np.float64))
    faces = np.asarray(mesh.faces, np.int64)
    longest = TABLE_EDGE * float(np.linalg.norm(np.ptp(vertices, axis=0)))
    while True:
        corners, bent = vertices[faces], normals[faces]
        edge = np.max([np.linalg.norm(corners[:, k] - corners[:, (k + 1) % 3], axis=1) for k in range(3)], axis=0)
        flat = (dot(bent[:, 0], bent[:, 1]) > 1.0 - 1e-6) & (dot(bent[:, 0], bent[:, 2]) > 1.0 - 1e-6)
        selected = flat & (edge > longest)
        if not selected.any() or len(vertices) + 3 * int(selected.sum()) > TABLE_VERTICES:
            break
        edges, faces = split_at_midpoints(faces, len(vertices), selected)
        vertices = np.concatenate([vertices, vertices[edges].mean(axis=1)])
        normals = np.concatenate([normals, normalize(normals[edges].sum(axis=1))])
    if len(vertices) == len(mesh.vertices):
        return mesh
    return Mesh(vertices.astype(np.float32), normals.astype(np.float32), faces.astype(np.int32), name=mesh.name)


# Tables -----------------------------------------------------------------------


def table_key(mesh, ior: float, directions: int, max_depth: int) -> tuple:
    return (mesh.geometry_hash(), round(float(ior), 9), int(directions), int(max_depth), TABLE_VERSION)


def table_path(mesh, ior: float, directions: int = DEFAULT_DIRECTIONS, max_depth: int = DEFAULT_MAX_DEPTH) -> Path:
    """Where the quantized table of ``mesh`` as glass of index ``ior`` is cached on disk."""
    return cache_dir("transport") / f"{mesh.geometry_hash()}-ior{float(ior):.6f}-d{directions}-k{max_depth}-v{TABLE_VERSION}.npz"


def has_cached_table(mesh, ior: float, directions: int = DEFAULT_DIRECTIONS, max_depth: int = DEFAULT_MAX_DEPTH) -> bool:
    """Whether that table is in memory or on disk (``caustica precompute`` or an earlier render made it);
    its content is checked only when it is loaded."""
    key = table_key(mesh, ior, directions, max_depth) + (True,)
    return _TABLES.get(key) is not None or table_path(mesh, ior, directions, max_depth).is_file()


def table_for(mesh, ior: float, directions: int = DEFAULT_DIRECTIONS, max_depth: int = DEFAULT_MAX_DEPTH,
              quantized: bool = True, progress: bool = True) -> TransportTable:
    """The (dequantized) transport table of ``mesh`` as glass of index ``ior``: from memory, the disk cache,
    or precomputed now (then cached under ``cache_dir('transport')``, keyed by mesh hash, IOR, sample count,
    depth and format version). ``quantized=False`` keeps the float table (memory only)."""
    key = table_key(mesh, ior, directions, max_depth) + (bool(quantized),)
    table = _TABLES.get(key)
    if table is not None:
        return table
    if not quantized:
        table = precompute_table(mesh, ior, directions, max_depth, progress=progress)
    else:
        path = table_path(mesh, ior, directions, max_depth)
        try:
            table = dequantize(load_table(path, mesh.geometry_hash(), ior, directions))
        except TransportTableError:
            q = quantize(precompute_table(mesh, ior, directions, max_depth, progress=progress))
            try:
                atomic_write_bytes(path, table_bytes(q))
            except OSError:
                pass  # an unwritable cache only costs a recompute
            table = dequantize(q)
    if len(table.exit_position) != len(mesh.vertices):
        raise TransportTableError(f"transport table has {len(table.exit_position)} vertices, the mesh {len(mesh.vertices)}")
    _TABLES[key] = table
    return table


# Lookup (5.1) -----------------------------------------------------------------


@dataclass
class Lookup:
    exit_position: np.ndarray  # (V, 3)
    exit_direction: np.ndarray  # (V, 3) unit
    transmittance: np.ndarray  # (V,) F_t times the unoccluded weight; 0 below the vertex's horizon
    lit: np.ndarray  # (V,) bool: the incident direction is above the vertex's tangent plane


def slerp(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Spherical linear interpolation of unit vectors (N, 3) (the rotation quaternions' slerp applied)."""
    cos = np.clip(dot(a, b), -1.0, 1.0)
    angle = np.arccos(cos)
    sin = np.sin(angle)
    small = sin < 1e-6
    safe = np.where(small, 1.0, sin)
    wa = np.where(small, 1.0 - t, np.sin((1.0 - t) * angle) / safe)
    wb = np.where(small, t, np.sin(t * angle) / safe)
    return normalize(wa[:, None] * a + wb[:, None] * b)


def lookup(table: TransportTable, frames: np.ndarray, incident: np.ndarray, vertices: np.ndarray | None = None) -> Lookup:
    """Interpolate the table for per-vertex incident directions (V, 3) (object space, towards the light).

    ``frames`` are the vertices' :func:`tangent_frames`; ``vertices`` (indices)
    picks table rows when only some vertices are looked up.
    """
    grid = table.grid
    rows = np.arange(len(incident)) if vertices is None else np.asarray(vertices)
    local = np.einsum("vij,vj->vi", frames, normalize(incident))
    lit = local[:, 2] > 0.0
    # The cell of the (ring, azimuth) grid around the direction.
    ring = np.arccos(np.clip(local[:, 2], 0.0, 1.0)) / (0.5 * np.pi) * grid.rings
    k0 = np.minimum(np.floor(ring), grid.rings - 1).astype(np.int64)
    fr = ring - k0
    az = np.mod(np.arctan2(local[:, 1], local[:, 0]), 2.0 * np.pi) / (2.0 * np.pi) * grid.azimuths
    j0 = np.floor(az).astype(np.int64)
    fa = az - j0
    corners = [grid.index(k0 + dk, j0 + dj) for dk in (0, 1) for dj in (0, 1)]
    weights = [(1 - fr) * (1 - fa), (1 - fr) * fa, fr * (1 - fa), fr * fa]
    # Bilinear position and transmittance; slerp of directions along azimuth, then elevation.
    position = sum(w[:, None] * table.exit_position[rows, c] for w, c in zip(weights, corners))
    open_t = table.transmittance * ~table.occluded
    transmittance = np.where(lit, sum(w * open_t[rows, c] for w, c in zip(weights, corners)), 0.0)
    d = [table.exit_direction[rows, c].astype(np.float64) for c in corners]
    direction = slerp(slerp(d[0], d[1], fa), slerp(d[2], d[3], fa), fr)
    return Lookup(position, direction, transmittance, lit)


# Photons (5.1 - 5.2 on the receivers) ----------------------------------------


def _incident(sample, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions towards the light (N, 3) and the irradiance perpendicular to it (N, 3) at world points."""
    if sample.type == LIGHT_DIRECTIONAL:
        direction = np.broadcast_to(-np.asarray(sample.direction, np.float64), points.shape).copy()
        return direction, np.broadcast_to(np.asarray(sample.intensity, np.float64), points.shape).copy()
    offset = np.asarray(sample.position, np.float64) - points
    r2 = np.maximum(dot(offset, offset), 1e-30)
    direction = offset / np.sqrt(r2)[:, None]
    falloff = 1.0 / r2
    if sample.type == LIGHT_SPOT:
        cos_in, cos_out = sample.cone_cos
        c = dot(-direction, np.broadcast_to(np.asarray(sample.direction, np.float64), direction.shape))
        t = np.clip((c - cos_out) / max(cos_in - cos_out, 1e-9), 0.0, 1.0)
        falloff = falloff * t * t * (3.0 - 2.0 * t)
    return direction, falloff[:, None] * np.asarray(sample.intensity, np.float64)


@dataclass
class ExitRays:
    """One glass object's refracted vertex rays in world space for one light sample."""

    origin: np.ndarray  # (V, 3)
    direction: np.ndarray  # (V, 3)
    weight: np.ndarray  # (V, 3) F_t times Beer-Lambert absorption, per channel
    entry: np.ndarray  # (V, 3) the vertices, where the rays enter
    faces: np.ndarray  # (F, 3) the table mesh's triangles (table_mesh), the illumination volumes' bases
    face_flux: np.ndarray  # (F, 3) E S entering each lit face (0 for unlit ones)
    # exit_rays="traced": traces rays from points inside the faces (SurfaceRays.at), for the volumes whose
    # three rays part (:func:`incoherent`); None: every volume is the blend of its vertex rays
    surface: "SurfaceRays | None" = None

    @property
    def volume_flux(self) -> np.ndarray:
        """(F, 3) the flux each illumination volume carries: E S times its three rays' mean weight (eq. 2)."""
        return self.face_flux * self.weight[self.faces].mean(axis=1)


def object_exit_rays(obj, sample, directions: int = DEFAULT_DIRECTIONS, max_depth: int = DEFAULT_MAX_DEPTH,
                     quantized: bool = True, progress: bool = True, traced: bool = False) -> list[ExitRays]:
    """The exit rays of glass ``obj`` lit by ``sample`` from the tables of its :func:`table_mesh`: one set, or
    for dispersive glass one per channel, each from the table of that channel's IOR and carrying that channel
    alone (the paper's table holds one IOR). ``traced``: traced for the light's own directions
    (:func:`traced_exit_rays`) instead of looked up."""
    material, mesh = obj.material, table_mesh(obj.mesh)
    if material.abbe is None:
        groups = [(float(material.ior), np.ones(3))]
    else:
        groups = [(float(ior), np.eye(3)[c]) for c, ior in enumerate(material.ior_rgb)]
    out = []
    for ior, channel in groups:
        if traced:
            rays = traced_exit_rays(obj, ior, sample, max_depth, channel)
        else:
            rays = exit_rays(obj, table_for(mesh, ior, directions, max_depth, quantized, progress), sample, channel)
        out.append(rays)
    return out


def exit_rays(obj, table: TransportTable, sample, channel=np.ones(3)) -> ExitRays:
    """Look the table up for ``obj`` (rigid transform) lit by ``sample`` (section 5.1); the table is its
    :func:`table_mesh`'s. ``channel`` scales the rays' weight (dispersive glass: one channel per table)."""
    mesh = table_mesh(obj.mesh)
    frame = _ObjectFrame(obj)
    towards, _ = _incident(sample, frame.world(mesh.vertices))
    found = lookup(table, vertex_frames(mesh), frame.to_object(towards))
    return _world_rays(obj, frame, mesh, found, sample, channel)


class _ObjectFrame:
    """An object's rigid transform (rotation, translation, uniform scale) applied to points and directions."""

    def __init__(self, obj):
        m = np.asarray(obj.world_from_object(), dtype=np.float64)
        self.a, self.t = m[:3, :3], m[:3, 3]

    def world(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points, np.float64) @ self.a.T + self.t

    def to_object(self, directions: np.ndarray) -> np.ndarray:
        return normalize(directions @ np.linalg.inv(self.a).T)

    def world_direction(self, directions: np.ndarray) -> np.ndarray:
        return normalize(np.asarray(directions, np.float64) @ self.a.T)


def _exit_weight(obj, entry: np.ndarray, origin: np.ndarray, transmittance: np.ndarray, channel) -> np.ndarray:
    """(N, 3) F_t times Beer-Lambert absorption over |x_out - P| (world), times ``channel``."""
    sigma = np.asarray(getattr(obj.material, "absorption_coefficient", np.zeros(3)), np.float64)
    inside = np.linalg.norm(origin - entry, axis=1)
    return transmittance[:, None] * np.exp(-sigma[None] * inside[:, None]) * channel


def _world_rays(obj, frame: _ObjectFrame, mesh, found: Lookup, sample, channel, surface=None) -> ExitRays:
    """The exit rays of ``found`` (object space, per vertex of ``mesh``) in world space, with the flux E S
    into each lit face (eq. 2)."""
    world = frame.world(mesh.vertices)
    origin = frame.world(found.exit_position)
    weight = _exit_weight(obj, world, origin, found.transmittance, channel)
    # Flux E S into each lit face (S: its area projected along the light).
    tri = world[mesh.faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    light_dir, irradiance = _incident(sample, tri.mean(axis=1))
    projected = np.maximum(0.5 * dot(cross, light_dir), 0.0)  # area * cos, 0 for faces turned away
    return ExitRays(origin, frame.world_direction(found.exit_direction), weight, world, mesh.faces,
                    irradiance * projected[:, None], surface)


# Traced exit rays (ours: the table's rays for the light's own directions) ------------


_GLASS_SCENES: LruCache = LruCache(8)


def _glass_rays(mesh, ior: float):
    """(scene, RayScene) of ``mesh`` alone as glass of index ``ior``: what the table is traced against."""
    key = (mesh.geometry_hash(), round(float(ior), 9))
    found = _GLASS_SCENES.get(key)
    if found is None:
        scene = glass_scene(mesh, ior)
        found = _GLASS_SCENES[key] = (scene, RayScene(scene))
    return found


@dataclass
class SurfaceRays:
    """Refracted rays from any point of a glass object's table mesh for one light sample, traced with Embree
    through the object as the table's samples are (:func:`~caustica.transport.precompute.trace_samples`)."""

    obj: object
    mesh: Mesh
    ior: float
    sample: object
    max_depth: int
    channel: np.ndarray

    def at(self, faces: np.ndarray, barycentric: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World exit origins, directions and weights (N, 3) of the rays entering at the points
        ``barycentric`` (N, 3) of the table-mesh triangles ``faces`` (N, 3) (normals interpolated)."""
        points = np.einsum("nc,ncx->nx", barycentric, self.mesh.vertices[faces].astype(np.float64))
        normals = normalize(np.einsum("nc,ncx->nx", barycentric, self.mesh.normals[faces].astype(np.float64)))
        found = self.trace(points, normals)
        frame = _ObjectFrame(self.obj)
        origin = frame.world(found.exit_position)
        weight = _exit_weight(self.obj, frame.world(points), origin, found.transmittance, self.channel)
        return origin, frame.world_direction(found.exit_direction), weight

    def trace(self, points: np.ndarray, normals: np.ndarray) -> Lookup:
        """What the table would hold at object-space ``points`` with ``normals`` for the light's own
        directions there: exit position, direction, F_t (0 where the object shades the point)."""
        frame = _ObjectFrame(self.obj)
        towards, _ = _incident(self.sample, frame.world(points))
        scene, rays = _glass_rays(self.mesh, self.ior)
        found = trace_samples(rays, scene, points, normals, frame.to_object(towards), self.ior, self.max_depth)
        transmittance = np.where(found["occluded"], 0.0, found["transmittance"])
        return Lookup(found["exit_position"], found["exit_direction"], transmittance, ~found["occluded"])


def traced_exit_rays(obj, ior: float, sample, max_depth: int = DEFAULT_MAX_DEPTH, channel=np.ones(3)) -> ExitRays:
    """The exit rays of ``obj`` for ``sample`` traced at every vertex of its :func:`table_mesh` for the light's
    own directions, instead of looked up (exit_rays="traced"): the table's content with no directional
    sampling, and the :class:`SurfaceRays` that trace the parting volumes' sub-rays."""
    mesh = table_mesh(obj.mesh)
    surface = SurfaceRays(obj, mesh, float(ior), sample, int(max_depth), np.asarray(channel, np.float64))
    found = surface.trace(mesh.vertices.astype(np.float64), normalize(mesh.normals.astype(np.float64)))
    return _world_rays(obj, _ObjectFrame(obj), mesh, found, sample, surface.channel, surface)


_FRAMES: LruCache = LruCache(64)  # an animated mesh has new geometry each frame


def vertex_frames(mesh) -> np.ndarray:
    key = mesh.geometry_hash()
    if key not in _FRAMES:
        _FRAMES[key] = tangent_frames(mesh.normals)
    return _FRAMES[key]


def subdivision_barycentrics(m: int) -> np.ndarray:
    """(m^2, 3) barycentric centroids of the m x m subdivision of a triangle (equal areas)."""
    i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    up = (i + j) <= m - 1
    down = (i + j) <= m - 2
    u = np.concatenate([(i[up] + 1 / 3) / m, (i[down] + 2 / 3) / m])
    v = np.concatenate([(j[up] + 1 / 3) / m, (j[down] + 2 / 3) / m])
    return np.stack([1.0 - u - v, u, v], axis=1)


@dataclass
class PhotonSet:
    position: np.ndarray  # (N, 3) where photons landed on receivers
    flux: np.ndarray  # (N, 3) W
    landed: np.ndarray  # (N,) bool
    stats: dict


def receiver_scene(receivers) -> RayScene:
    return RayScene.from_meshes([o.world_mesh() for o in receivers])


PARTING_SPREAD = 4.0  # a volume parts where its exit points lie more than this many of its face's edges apart,
PARTING_COS = float(np.cos(np.radians(15.0)))  # or its exit directions more than 15 degrees


def parting(rays: ExitRays, faces: np.ndarray) -> np.ndarray:
    """(F,) bool: the volumes of ``faces`` whose three rays do not stay together: exit points more than
    PARTING_SPREAD of the face's longest edge apart, or directions more than 15 degrees apart. Their rays took
    different paths through the object (one through an ear and into the body, one out of a hole, one
    reflected inside), so a blend of them (eq. 2's volume) lights places no light reaches."""
    corners = rays.origin[faces]  # (F, 3, 3) exit points
    entry_edge = np.zeros(len(faces))
    spread = np.zeros(len(faces))
    cos = np.ones(len(faces))
    for k in range(3):
        a, b = faces[:, k], faces[:, (k + 1) % 3]
        spread = np.maximum(spread, np.linalg.norm(corners[:, k] - corners[:, (k + 1) % 3], axis=1))
        cos = np.minimum(cos, dot(rays.direction[a], rays.direction[b]))
        entry_edge = np.maximum(entry_edge, np.linalg.norm(rays.entry[a] - rays.entry[b], axis=1))
    return (spread > PARTING_SPREAD * entry_edge) | (cos < PARTING_COS)


def caustic_photons(rays: ExitRays, receivers: RayScene, budget: int, plane_cos: float = 0.9999) -> PhotonSet:
    """Photons on the receivers from one object's illumination volumes (eq. 2; see the module docstring).
    With ``rays.surface`` (exit_rays="traced") the parting volumes (:func:`parting`) send their m^2 sub-rays
    from points inside the face, each traced through the object, instead of blends of the vertex rays."""
    flux = rays.volume_flux
    if rays.surface is not None:  # a parting volume's flux is its sub-rays' own (E S / m^2 times each's F_t)
        flux = np.where(parting(rays, rays.faces)[:, None], rays.face_flux, flux)
    lit = flux.max(axis=1) > 0
    faces, flux = rays.faces[lit], flux[lit]
    empty = PhotonSet(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, bool), {"faces": 0, "planar": 0})
    if len(faces) == 0:
        return empty
    # Land the vertex rays of the lit faces exactly.
    used = np.unique(faces)
    hits = receivers.intersect(rays.origin[used], rays.direction[used])
    slot = np.full(len(rays.origin), -1)
    slot[used] = np.arange(len(used))
    f = slot[faces]
    landed = hits.position[f]  # (F, 3, 3)
    all_hit = hits.hit[f].all(axis=1)
    same = (hits.object_index[f] == hits.object_index[f][:, :1]).all(axis=1)
    n = hits.geometric_normal[f]
    coplanar = (dot(n[:, 1], n[:, 0]) > plane_cos) & (dot(n[:, 2], n[:, 0]) > plane_cos)
    split = parting(rays, faces) if rays.surface is not None else np.zeros(len(faces), bool)
    planar = all_hit & same & coplanar & ~split
    # Photon count per volume: half the budget by S_p (uniform cover of the receivers), half by flux
    # (every bright volume gets several photons).
    span = np.where(all_hit, 0.5 * np.linalg.norm(np.cross(landed[:, 1] - landed[:, 0], landed[:, 2] - landed[:, 0]), axis=1), 0.0)
    span = np.where(all_hit, span, np.nanmax(np.append(span, 0.0)))  # spread-out volumes get many sub-rays
    power = flux.sum(axis=1)
    share = 0.5 * budget * (span / max(float(span.sum()), 1e-30) + power / max(float(power.sum()), 1e-30))
    sub = np.clip(np.ceil(np.sqrt(share)), 1, MAX_SUBDIVISION).astype(np.int64)
    positions, fluxes, landed_mask = [], [], []
    for m in np.unique(sub):
        pick = sub == m
        bary = subdivision_barycentrics(int(m))  # (m^2, 3)
        on_plane = planar[pick]
        # Planar volumes: the landed triangle is S_p; photons at its sub-centroids.
        p_plane = np.einsum("kc,fcx->fkx", bary, landed[pick][on_plane]).reshape(-1, 3)
        positions.append(p_plane)
        fluxes.append(np.repeat(flux[pick][on_plane] / (m * m), len(bary), axis=0))
        landed_mask.append(np.ones(len(p_plane), bool))
        # The rest: blend the vertex rays and land each sub-ray.
        blend = ~on_plane & ~split[pick]
        rest = faces[pick][blend]
        if len(rest):
            o = np.einsum("kc,fcx->fkx", bary, rays.origin[rest]).reshape(-1, 3)
            d = normalize(np.einsum("kc,fcx->fkx", bary, rays.direction[rest]).reshape(-1, 3))
            h = receivers.intersect(o, d)
            positions.append(h.position)
            fluxes.append(np.repeat(flux[pick][blend] / (m * m), len(bary), axis=0))
            landed_mask.append(h.hit)
        # Parting volumes: trace each sub-ray from its point inside the face.
        parted = faces[pick][split[pick]]
        if len(parted):
            o, d, w = rays.surface.at(np.repeat(parted, len(bary), axis=0), np.tile(bary, (len(parted), 1)))
            h = receivers.intersect(o, d)
            positions.append(h.position)
            fluxes.append(np.repeat(flux[pick][split[pick]] / (m * m), len(bary), axis=0) * w)
            landed_mask.append(h.hit & (w.max(axis=1) > 0))
    position, photon_flux, mask = np.concatenate(positions), np.concatenate(fluxes), np.concatenate(landed_mask)
    stats = {"faces": int(len(faces)), "planar": int(planar.sum()), "parting": int(split.sum()),
             "photons": int(len(position)),
             "flux_in": photon_flux.sum(axis=0).tolist(), "flux_landed": photon_flux[mask].sum(axis=0).tolist()}
    return PhotonSet(position, photon_flux, mask, stats)
