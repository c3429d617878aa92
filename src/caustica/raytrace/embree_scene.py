"""Exact ray queries against a scene on the CPU, through Embree (embreex).

:class:`RayScene` holds every object's world-space triangle mesh in one Embree
scene. Embree works in float32; each hit is then recomputed in float64 from the
barycentric coordinates on the triangle, and the shading normal is the
barycentric interpolation of the smooth vertex normals (normalised), which is
what an exact specular tracer needs.

Analytic spheres: a mesh that carries the attribute ``analytic_sphere =
(center, radius)`` (object space; ``caustica.scene.shapes.sphere`` sets it) is
intersected as the true sphere in closed form, with the exact radial normal,
instead of as triangles, as long as its transform scales uniformly. This makes
the oracle exact for the closed-form tests (exit directions through a ball);
pass ``analytic_spheres=False`` to trace the tessellation instead.

Rays are processed in chunks (at most ``chunk_size`` rays at a time) on a
thread pool: embreex releases the GIL while it traverses.
"""
from __future__ import annotations

import os
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..cache import kept_on
from ..scene.mesh import Mesh
from .optics import dot

CHUNK_SIZE = 1 << 20
_GEOMETRY_CACHE: OrderedDict[tuple, "_Geometry"] = OrderedDict()
_GEOMETRY_CACHE_SIZE = 32  # entries kept at most
# Bytes kept at most (the newest entry always stays): an animated mesh is new geometry every frame,
# so a bound on the count alone lets large animated meshes fill memory (docs/benchmarks-archive.md, "Soak").
_GEOMETRY_CACHE_BYTES = 64 << 20


@dataclass
class Hits:
    """Nearest hits of N rays. Misses have ``hit`` False, ``t`` inf, ``object_index`` -1.

    Normals are unit length and keep the mesh's orientation (outward for a closed
    mesh with counter-clockwise faces); they are not flipped towards the ray.
    """

    hit: np.ndarray  # (N,) bool
    t: np.ndarray  # (N,) float64 distance along the (unit) direction
    position: np.ndarray  # (N,3) float64
    normal: np.ndarray  # (N,3) float64 interpolated shading normal
    geometric_normal: np.ndarray  # (N,3) float64 face normal
    object_index: np.ndarray  # (N,) int32 index into the scene's objects
    face: np.ndarray  # (N,) int64 face index in the object's mesh, -1 for analytic spheres
    barycentric: np.ndarray  # (N,3) float64 weights of the face's corners (world mesh order), 0 off triangles


@dataclass
class _Geometry:
    """One object prepared for tracing: float64 triangles or an analytic sphere."""

    vertices32: np.ndarray | None  # (V,3) float32, what Embree sees
    faces: np.ndarray | None  # (M,3) int32
    triangles: np.ndarray | None  # (M,3,3) float64 corner positions
    corner_normals: np.ndarray | None  # (M,3,3) float64 vertex normals per corner
    face_normals: np.ndarray | None  # (M,3) float64 unit
    sphere: tuple[np.ndarray, float] | None  # world-space (center, radius)
    bounds: np.ndarray  # (2,3)

    @property
    def nbytes(self) -> int:
        arrays = (self.vertices32, self.faces, self.triangles, self.corner_normals, self.face_normals, self.bounds)
        return sum(a.nbytes for a in arrays if a is not None)


def world_sphere(mesh: Mesh, world_from_object: np.ndarray) -> tuple[np.ndarray, float] | None:
    """The world-space (center, radius) of ``mesh.analytic_sphere``, or None.

    None when the mesh has no such attribute, has uvs (a texture is looked up on its triangles), or the
    transform does not scale uniformly (the sphere would become an ellipsoid).
    """
    sphere = getattr(mesh, "analytic_sphere", None)
    if sphere is None or mesh.uvs is not None:
        return None
    m = np.asarray(world_from_object, dtype=np.float64)
    scales = np.linalg.norm(m[:3, :3], axis=0)
    if np.ptp(scales) > 1e-9 * scales.max():
        return None
    center = m[:3, :3] @ np.asarray(sphere[0], dtype=np.float64) + m[:3, 3]
    return center, float(sphere[1]) * float(scales[0])


def _prepare(mesh: Mesh, sphere) -> _Geometry:
    """Float64 triangle data for ``mesh`` (already in world space), or the analytic sphere."""
    if sphere is not None:
        center, radius = sphere
        return _Geometry(None, None, None, None, None, sphere, np.stack([center - radius, center + radius]))
    v = mesh.vertices.astype(np.float64)
    tris = v[mesh.faces]
    face_n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    length = np.linalg.norm(face_n, axis=1, keepdims=True)
    face_n = np.where(length > 0, face_n / np.maximum(length, 1e-300), 0.0)
    corner_n = mesh.normals.astype(np.float64)[mesh.faces]
    return _Geometry(mesh.vertices, mesh.faces, tris, corner_n, face_n, None, mesh.bounds.astype(np.float64))


def _cached_geometry(mesh: Mesh, world_from_object: np.ndarray | None, world_mesh, analytic: bool) -> _Geometry:
    """Prepared geometry, cached by mesh content and transform (the ``_GEOMETRY_CACHE_SIZE`` most
    recently used entries, at most ``_GEOMETRY_CACHE_BYTES`` together)."""
    xform = np.eye(4) if world_from_object is None else np.asarray(world_from_object, dtype=np.float64)
    sphere = world_sphere(mesh, xform) if analytic else None
    key = (mesh.content_hash(), hash(mesh.normals.tobytes()), xform.tobytes(), sphere is not None)
    geometry = _GEOMETRY_CACHE.get(key)
    if geometry is None:
        geometry = _prepare(world_mesh() if sphere is None else None, sphere)
        _GEOMETRY_CACHE[key] = geometry
        total = sum(g.nbytes for g in _GEOMETRY_CACHE.values())
        while len(_GEOMETRY_CACHE) > 1 and (len(_GEOMETRY_CACHE) > _GEOMETRY_CACHE_SIZE or total > _GEOMETRY_CACHE_BYTES):
            total -= _GEOMETRY_CACHE.popitem(last=False)[1].nbytes
    else:
        _GEOMETRY_CACHE.move_to_end(key)
    return geometry


def _sphere_roots(o: np.ndarray, d: np.ndarray, center: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Both ray parameters where o + t d meets the sphere (t0 <= t1; NaN when it misses).

    Uses the cancellation-free form q = -(b + sign(b) sqrt(disc)), roots q and c/q.
    """
    oc = o - center
    b = dot(oc, d)
    c = dot(oc, oc) - radius * radius
    disc = b * b - c
    with np.errstate(invalid="ignore", divide="ignore"):
        q = -(b + np.copysign(np.sqrt(disc), b))
        r0, r1 = q, c / q
    r0 = np.where(q == 0, 0.0, r0)
    r1 = np.where(q == 0, 0.0, r1)
    return np.minimum(r0, r1), np.maximum(r0, r1)


def _triangle_hits(o, d, triangles, u32, v32) -> tuple[np.ndarray, np.ndarray]:
    """Ray parameter and barycentrics (n,3) of rays on the triangles they hit, in float64.

    Moller-Trumbore on the known triangle; where the ray is parallel to its
    plane, Embree's float32 barycentrics are kept.
    """
    v0 = triangles[:, 0]
    e1, e2 = triangles[:, 1] - v0, triangles[:, 2] - v0
    pvec = np.cross(d, e2)
    det = dot(e1, pvec)
    ok = np.abs(det) > 1e-300
    inv = 1.0 / np.where(ok, det, 1.0)
    tvec = o - v0
    qvec = np.cross(tvec, e1)
    u = np.where(ok, dot(tvec, pvec) * inv, u32)
    v = np.where(ok, dot(d, qvec) * inv, v32)
    bary = np.stack([1.0 - u - v, u, v], axis=1)
    on_triangle = np.einsum("ik,ikj->ij", bary, triangles)
    t = np.where(ok, dot(e2, qvec) * inv, dot(on_triangle - o, d))
    return t, bary


class RayScene:
    """Embree scene of every object in a :class:`~caustica.scene.scene.Scene` (world space).

    ``object_index`` in the hits indexes ``scene.objects``. Build once per scene
    layout; :func:`ray_scene_for` caches one on the scene.
    """

    def __init__(self, scene, analytic_spheres: bool = True, chunk_size: int = CHUNK_SIZE, threads: int | None = None):
        geometries = [
            _cached_geometry(obj.mesh, obj.world_from_object(), obj.world_mesh, analytic_spheres)
            for obj in scene.objects
        ]
        self._build(geometries, chunk_size, threads)

    @classmethod
    def from_meshes(cls, meshes, analytic_spheres: bool = False, chunk_size: int = CHUNK_SIZE, threads=None) -> "RayScene":
        """A ray scene of meshes already in world space (object index = position in the list)."""
        self = cls.__new__(cls)
        geometries = [_cached_geometry(m, None, lambda m=m: m, analytic_spheres) for m in meshes]
        self._build(geometries, chunk_size, threads)
        return self

    def _build(self, geometries: list[_Geometry], chunk_size: int, threads: int | None) -> None:
        import embreex.rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh

        self.chunk_size = int(chunk_size)
        self.threads = max(1, threads or os.cpu_count() or 1)
        self.spheres = [(i, g.sphere[0], g.sphere[1]) for i, g in enumerate(geometries) if g.sphere is not None]
        meshes = [(i, g) for i, g in enumerate(geometries) if g.sphere is None]
        # Merge every triangle mesh into one Embree geometry; face ranges map back to objects.
        self._embree = None
        if meshes:
            offsets = np.cumsum([0] + [len(g.vertices32) for _, g in meshes])
            vertices = np.concatenate([g.vertices32 for _, g in meshes])
            faces = np.concatenate([g.faces + off for (_, g), off in zip(meshes, offsets)])
            self._triangles = np.concatenate([g.triangles for _, g in meshes])
            self._corner_normals = np.concatenate([g.corner_normals for _, g in meshes])
            self._face_normals = np.concatenate([g.face_normals for _, g in meshes])
            counts = [len(g.faces) for _, g in meshes]
            self._face_object = np.repeat(np.array([i for i, _ in meshes], dtype=np.int32), counts)
            self._face_start = np.repeat(np.cumsum([0] + counts)[:-1], counts)
            self._embree = rtcs.EmbreeScene()
            TriangleMesh(self._embree, np.ascontiguousarray(vertices), np.ascontiguousarray(faces, dtype=np.int32))
            # Commit now, on one thread (embreex commits lazily on the first query).
            self._embree.run(np.zeros((1, 3), np.float32), np.array([[0, 0, 1]], np.float32))
        if geometries:
            lo = np.min([g.bounds[0] for g in geometries], axis=0)
            hi = np.max([g.bounds[1] for g in geometries], axis=0)
            diagonal = float(np.linalg.norm(hi - lo))
        else:
            diagonal = 1.0
        # Default tnear: a scale-aware offset that skips the surface a ray starts on.
        self.epsilon = 1e-5 * max(diagonal, 1e-12)
        self.rays_traced = 0  # every ray through intersect() and occluded(), for throughput figures

    # -- queries -----------------------------------------------------------------

    def _chunks(self, n: int):
        """Slices of at most ``chunk_size`` rays, enough of them to keep every thread busy."""
        size = min(self.chunk_size, max(4096, -(-n // self.threads)))
        return [slice(s, min(s + size, n)) for s in range(0, n, size)]

    def _map_chunks(self, fn, n: int) -> None:
        chunks = self._chunks(n)
        if len(chunks) <= 1:
            for sl in chunks:
                fn(sl)
            return
        with ThreadPoolExecutor(self.threads) as pool:
            list(pool.map(fn, chunks))

    def intersect(self, origins: np.ndarray, dirs: np.ndarray, tnear: float | None = None) -> Hits:
        """Nearest hit along each ray beyond ``tnear`` (default :attr:`epsilon`).

        ``origins`` and ``dirs`` are (N,3); directions must be unit length so that
        ``t`` is a distance.
        """
        o = np.ascontiguousarray(origins, dtype=np.float64).reshape(-1, 3)
        d = np.ascontiguousarray(dirs, dtype=np.float64).reshape(-1, 3)
        tnear = self.epsilon if tnear is None else float(tnear)
        n = len(o)
        self.rays_traced += n
        out = Hits(
            hit=np.zeros(n, bool),
            t=np.full(n, np.inf),
            position=np.zeros((n, 3)),
            normal=np.zeros((n, 3)),
            geometric_normal=np.zeros((n, 3)),
            object_index=np.full(n, -1, np.int32),
            face=np.full(n, -1, np.int64),
            barycentric=np.zeros((n, 3)),
        )

        def run(sl: slice) -> None:
            self._intersect_chunk(o[sl], d[sl], tnear, out, sl)

        self._map_chunks(run, n)
        return out

    def _intersect_chunk(self, o: np.ndarray, d: np.ndarray, tnear: float, out: Hits, sl: slice) -> None:
        n = len(o)
        t = np.full(n, np.inf)
        prim = np.full(n, -1, np.int64)
        obj = np.full(n, -1, np.int32)
        # Triangles: Embree in float32 from the origin moved by tnear (embreex fixes tnear at 0).
        if self._embree is not None:
            res = self._embree.run(
                (o + tnear * d).astype(np.float32), d.astype(np.float32), dists=np.full(n, 1e30, np.float32), output=1
            )
            prim = res["primID"].astype(np.int64)
            found = prim >= 0
            t[found] = tnear + res["tfar"][found]
            obj[found] = self._face_object[prim[found]]
            u, v = res["u"].astype(np.float64), res["v"].astype(np.float64)
        # Analytic spheres: the nearest root beyond tnear, where it is nearer than the triangles.
        for index, center, radius in self.spheres:
            t0, t1 = _sphere_roots(o, d, center, radius)
            ts = np.where(t0 > tnear, t0, np.where(t1 > tnear, t1, np.inf))
            closer = ts < t
            t[closer], obj[closer], prim[closer] = ts[closer], index, -1
        # Mesh hits: the ray re-intersected with the hit triangle in float64 (Moller-Trumbore),
        # the shading normal interpolated with those barycentrics.
        tri = prim >= 0
        if tri.any():
            f = prim[tri]
            t[tri], bary = _triangle_hits(o[tri], d[tri], self._triangles[f], u[tri], v[tri])
            p = o[tri] + t[tri, None] * d[tri]
            ns = np.einsum("ik,ikj->ij", bary, self._corner_normals[f])
            ng = self._face_normals[f]
            length = np.linalg.norm(ns, axis=1, keepdims=True)
            ns = np.where(length > 1e-12, ns / np.maximum(length, 1e-300), ng)
            idx = np.arange(sl.start, sl.stop)[tri]
            out.position[idx], out.normal[idx], out.geometric_normal[idx] = p, ns, ng
            out.face[idx] = f - self._face_start[f]
            out.barycentric[idx] = bary
        # Sphere hits: the point snapped onto the sphere, the exact radial normal.
        for index, center, radius in self.spheres:
            on = (obj == index) & (prim < 0)
            if on.any():
                radial = o[on] + t[on, None] * d[on] - center
                radial /= np.linalg.norm(radial, axis=1, keepdims=True)
                idx = np.arange(sl.start, sl.stop)[on]
                out.position[idx] = center + radius * radial
                out.normal[idx] = out.geometric_normal[idx] = radial
        out.hit[sl] = obj >= 0
        out.t[sl] = t
        out.object_index[sl] = obj

    def occluded(self, origins: np.ndarray, dirs: np.ndarray, max_t, tnear: float | None = None) -> np.ndarray:
        """(N,) bool: whether anything lies along each ray between ``tnear`` and ``max_t``.

        ``max_t`` is a scalar or (N,) array; np.inf means unbounded (directional light).
        """
        o = np.ascontiguousarray(origins, dtype=np.float64).reshape(-1, 3)
        d = np.ascontiguousarray(dirs, dtype=np.float64).reshape(-1, 3)
        tnear = self.epsilon if tnear is None else float(tnear)
        max_t = np.broadcast_to(np.asarray(max_t, dtype=np.float64), (len(o),))
        self.rays_traced += len(o)
        blocked = np.zeros(len(o), bool)

        def run(sl: slice) -> None:
            oc, dc, tmax = o[sl], d[sl], max_t[sl]
            hit = np.zeros(len(oc), bool)
            if self._embree is not None:
                dists = np.clip(tmax - tnear, 0.0, 1e30).astype(np.float32)
                res = self._embree.run((oc + tnear * dc).astype(np.float32), dc.astype(np.float32), dists=dists, query="OCCLUDED")
                hit |= res >= 0
            for _, center, radius in self.spheres:
                t0, t1 = _sphere_roots(oc, dc, center, radius)
                hit |= ((t0 > tnear) & (t0 < tmax)) | ((t1 > tnear) & (t1 < tmax))
            blocked[sl] = hit

        self._map_chunks(run, len(o))
        return blocked


def ray_scene_for(scene, analytic_spheres: bool = True) -> RayScene:
    """The :class:`RayScene` of ``scene``, cached on the scene until an object, mesh or transform changes."""
    key = (analytic_spheres,) + tuple(
        (id(o.mesh), o.mesh.content_hash(), o.world_from_object().tobytes(), getattr(o.mesh, "analytic_sphere", None) is not None)
        for o in scene.objects
    )
    return kept_on(scene, "_ray_scene_cache", key, lambda: RayScene(scene, analytic_spheres=analytic_spheres))
