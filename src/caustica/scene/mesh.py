"""Triangle meshes: vertex positions, smooth per-vertex normals, faces.

Meshes are pure data (numpy); the GPU and Embree layers upload them as needed.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import MeshError, short
from . import rules
from .transform import normal_matrix

SUPPORTED_MESH_SUFFIXES = (".obj", ".ply", ".stl", ".glb", ".gltf", ".off")
SPHERE_SAGITTA = 2e-3  # face_solid: how far (of the mesh's size) a facet's centroid may lie off the sphere it stands on


@dataclass
class Mesh:
    """An indexed triangle mesh in object space.

    ``vertices`` (N,3) float32, ``normals`` (N,3) float32 unit length (smooth: the
    exact oracle interpolates them), ``faces`` (M,3) int32 counter-clockwise seen
    from outside, ``uvs`` (N,2) float32 texture coordinates or None (glTF's TEXCOORD_0
    convention: (0, 0) is the image's top-left corner), ``tangents`` (N,4) float32 or None: a file's own
    tangent frames for normal maps (glTF's TANGENT: unit xyz along +u, w = +-1 the handedness;
    scene/tangents.py generates them from the uvs where the file has none).
    """

    vertices: np.ndarray
    normals: np.ndarray
    faces: np.ndarray
    name: str = "mesh"
    # (center, radius) in object space when the mesh tessellates an exact sphere:
    # the exact oracle then intersects the true sphere (raytrace/embree_scene.py).
    analytic_sphere: tuple | None = None
    uvs: np.ndarray | None = None
    tangents: np.ndarray | None = None
    _hash: str | None = field(default=None, repr=False, compare=False)
    _bounds: np.ndarray | None = field(default=None, repr=False, compare=False)
    _open: bool | None = field(default=None, repr=False, compare=False)
    _solid: bool | None = field(default=None, repr=False, compare=False)
    _convex: bool | None = field(default=None, repr=False, compare=False)
    _planes: dict = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self):
        self.validate(normals_missing=self.normals is None)

    def validate(self, normals_missing: bool = False) -> None:
        """Raise MeshError when the mesh is empty, non-finite, beyond rules.MAX_COORDINATE, above
        rules.MAX_TRIANGLES or badly indexed; arrays assigned since construction are checked and converted
        again (float32 vertices and normals, int32 faces), and the cached bounds refreshed."""
        label = f"mesh {short(self.name)}"
        vertices = _numeric(self.vertices, label, "vertex positions")
        faces = _numeric(self.faces, label, "faces")
        bounds = check_positions(vertices, label)
        check_faces(faces, len(vertices), label)
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float32)
        self.faces = np.ascontiguousarray(faces, dtype=np.int32)
        if normals_missing:
            self.normals = vertex_normals(self.vertices, self.faces)
        normals = _numeric(self.normals, label, "normals")
        if normals.shape != vertices.shape or not -2.0 <= float(normals.min()) <= float(normals.max()) <= 2.0:
            raise MeshError(f"{label} has invalid normals; drop them so caustica recomputes them")
        self.normals = np.ascontiguousarray(normals, dtype=np.float32)
        if self.uvs is not None:
            uvs = _numeric(self.uvs, label, "texture coordinates")
            if uvs.shape != (len(vertices), 2) or not np.all(np.isfinite(uvs)):
                raise MeshError(f"{label} has {short(uvs.shape)} texture coordinates for {len(vertices)} vertices; "
                                "give one finite (u, v) per vertex or none")
            self.uvs = np.ascontiguousarray(uvs, dtype=np.float32)
        if self.tangents is not None:
            self.tangents = _checked_tangents(self.tangents, len(vertices), label)
        self._bounds = bounds.astype(np.float32)

    @property
    def bounds(self) -> np.ndarray:
        """(2,3) array: min and max corner (computed once; meshes are not edited in place)."""
        if self._bounds is None:
            self._bounds = np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)])
        return self._bounds

    def content_hash(self) -> str:
        """A stable hash of the geometry (and the uvs, where given), for on-disk caches."""
        if self._hash is None:
            import hashlib

            h = hashlib.sha1()
            h.update(self.vertices.tobytes())
            h.update(self.faces.tobytes())
            if self.uvs is not None:  # a textured mesh is drawn with its uvs (GPU meshes are kept by this hash)
                h.update(b"uvs")
                h.update(self.uvs.tobytes())
            if self.tangents is not None:  # a file's own tangent frames shade its normal maps
                h.update(b"tangents")
                h.update(self.tangents.tobytes())
            self._hash = h.hexdigest()[:16]
        return self._hash

    def is_open(self) -> bool:
        """Whether some edge borders one triangle only (a water surface rather than a solid).

        Vertices are welded by position first: icospheres and revolved shapes may
        repeat vertices along seams.
        """
        if self._open is None:
            _, uses, _, _ = self._undirected_edges()
            self._open = bool(np.any(uses == 1))
        return self._open

    def _undirected_edges(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """The welded mesh's undirected edges (E, 2) int64 (lower index first), how many faces use each
        (E,), each vertex's welded index and the welded vertex count."""
        weld, count = self._weld()
        edges = np.sort(weld[self.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)].astype(np.int64), axis=1)
        codes, uses = np.unique(edges[:, 0] * count + edges[:, 1], return_counts=True)
        return np.stack([codes // count, codes % count], axis=1), uses, weld, count

    def _welded_edges(self) -> tuple[np.ndarray, int]:
        """Directed edges (a, b) of every face, counter-clockwise, with vertices welded by position
        (icospheres and revolved shapes may repeat vertices along seams; + 0.0 welds -0 to 0):
        (3M, 2) int64 and the welded vertex count."""
        weld, count = self._weld()
        return weld[self.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)].astype(np.int64), count

    def _weld(self) -> tuple[np.ndarray, int]:
        """Each vertex's welded index (by position, see :meth:`_welded_edges`) and the welded count."""
        _, first, weld = np.unique((np.round(self.vertices, 6) + 0.0).view(np.dtype((np.void, 12))).reshape(-1),
                                   return_index=True, return_inverse=True)
        return weld.reshape(-1), len(first)

    def concave_fraction(self, eye) -> float:
        """The fraction of the interior (welded) vertices where the surface bends towards ``eye``'s side:
        the umbrella Laplacian (mean of the neighbours less the vertex, along the mean curvature normal)
        points to the side of the vertex normal that faces ``eye``, by more than 1e-3 of the mean edge.
        A concave mirror seen from its hollow is 1, a convex or flat one 0, a saddle about 0."""
        undirected, uses, weld, count = self._undirected_edges()
        position = np.zeros((count, 3))
        position[weld] = self.vertices
        normal = np.zeros((count, 3))
        np.add.at(normal, weld, self.normals.astype(np.float64))
        eye_side = np.sign(np.einsum("ij,ij->i", normal, np.asarray(eye, np.float64) - position))
        neighbours = np.zeros((count, 3))
        degree = np.zeros(count)
        for a, b in ((0, 1), (1, 0)):
            np.add.at(neighbours, undirected[:, a], position[undirected[:, b]])
            np.add.at(degree, undirected[:, a], 1.0)
        laplacian = neighbours / np.maximum(degree, 1.0)[:, None] - position
        # Interior vertices only: a border vertex's neighbours all lie to one side.
        border = np.zeros(count, bool)
        border[undirected[uses == 1].reshape(-1)] = True
        inside = ~border & (degree > 0)
        if not inside.any():
            return 0.0
        edge = float(np.linalg.norm(position[undirected[:, 0]] - position[undirected[:, 1]], axis=1).mean())
        bend = np.einsum("ij,ij->i", laplacian, normal) * eye_side / np.maximum(np.linalg.norm(normal, axis=1), 1e-12)
        return float(np.mean(bend[inside] > 1e-3 * edge))

    def is_solid(self) -> bool:
        """Whether the mesh bounds a volume with its front faces outside: every welded edge is shared
        by exactly two faces that run along it in opposite directions, and the signed volume is positive.

        From outside a solid's bounds every back face lies behind a front face of the same mesh, so
        a rasterizer may cull back faces (ShadeSurfaces does).
        """
        if self._solid is None:
            edges, count = self._welded_edges()
            forward = np.sort(edges[:, 0] * count + edges[:, 1])
            backward = np.sort(edges[:, 1] * count + edges[:, 0])
            solid = (not np.any(edges[:, 0] == edges[:, 1]) and np.array_equal(forward, backward)
                     and not np.any(forward[1:] == forward[:-1]))
            if solid:
                v = self.vertices.astype(np.float64)[self.faces]
                solid = float(np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum()) > 0.0
            self._solid = bool(solid)
        return self._solid

    def is_convex(self, tolerance: float = 1e-4) -> bool:
        """Whether the mesh is closed and bends outwards at every edge: the far vertex of each face's
        neighbour across an edge lies on or behind the face's plane (within ``tolerance`` of the mesh's
        size). A closed surface convex at every edge bounds a convex body, which a straight ray enters and
        leaves once: two interfaces (what image-space two-interface refraction assumes, Wyman 2005)."""
        if self._convex is None:
            edges, count = self._welded_edges()
            key = edges[:, 0] * count + edges[:, 1]
            reverse = edges[:, 1] * count + edges[:, 0]
            order = np.argsort(key)
            found = np.clip(np.searchsorted(key[order], reverse), 0, len(key) - 1)
            other = order[found]
            convex = bool(np.all(key[other] == reverse))  # every edge has its twin: closed
            if convex:
                v = self.vertices.astype(np.float64)
                corners = v[self.faces]
                normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
                length = np.linalg.norm(normal, axis=1)
                face, neighbour = np.arange(len(key)) // 3, other // 3
                far = self.faces[neighbour, (other % 3 + 2) % 3]  # the neighbour's vertex off the shared edge
                height = np.einsum("ij,ij->i", normal[face], v[far] - corners[face, 0])
                size = float(np.ptp(v, axis=0).max())
                usable = length[face] > 1e-12 * size * size
                convex = bool(np.all(height[usable] <= tolerance * size * length[face][usable]))
            self._convex = convex
        return self._convex

    def face_planes(self, max_planes: int, tolerance: float = 1e-4) -> np.ndarray | None:
        """The planes of a convex polyhedron's faces, (K, 4) float64: outward unit normal xyz and offset w
        (n . x = w on the face, n . x <= w inside), one row per distinct plane; None when the mesh is not
        convex (:meth:`is_convex`) or its faces lie on more than ``max_planes`` planes.
        The body is the intersection of these half-spaces, so a ray inside leaves it where it crosses the
        first plane it moves towards (Haines, "Fast ray-convex polyhedron intersection", Graphics Gems II)."""
        found = self._grouped_planes(max_planes, tolerance)
        return None if found is None else found[0]

    def face_plane_normals(self, max_planes: int, tolerance: float = 1e-4) -> np.ndarray | None:
        """The shading normal on each of :meth:`face_planes`' planes as an affine field, (K, 3, 4) float64: row i
        of plane k gives component i, ``field[k] @ (x, y, z, 1)`` (unnormalised), fitted by least squares to the
        vertex normals of the faces on that plane. Barycentric interpolation is affine on one triangle; a plane of
        several triangles has one field where their normals agree with it (flat faces, a cylinder's side quads,
        normals (x - c) / r of a sphere or a capsule). None where :meth:`face_planes` is, or where some plane's
        vertex normals miss their field by more than 1e-3."""
        found = self._grouped_planes(max_planes, tolerance)
        if found is None:
            return None
        key = (int(max_planes), float(tolerance), "normals")
        if key not in self._planes:
            self._planes[key] = self._plane_normals(found[1], len(found[0]))
        return self._planes[key]

    def _plane_normals(self, label: np.ndarray, count: int) -> np.ndarray | None:
        fields = np.zeros((count, 3, 4))
        for k in range(count):
            corners = np.unique(self.faces[label == k].ravel())
            centre = self.vertices[corners].astype(np.float64).mean(axis=0)  # about it a flat face's field is constant
            points = np.column_stack([self.vertices[corners] - centre, np.ones(len(corners))])
            normals = self.normals[corners].astype(np.float64)
            fit = np.linalg.lstsq(points, normals, rcond=None)[0].T
            if np.abs(points @ fit.T - normals).max() > 1e-3:
                return None
            fields[k] = np.column_stack([fit[:, :3], fit[:, 3] - fit[:, :3] @ centre])
        return fields

    def _grouped_planes(self, max_planes: int, tolerance: float) -> tuple[np.ndarray, np.ndarray] | None:
        """(planes (K, 4), the plane of each face (M,), -1 for degenerate faces), or None; cached."""
        key = (int(max_planes), float(tolerance))
        if key not in self._planes:
            self._planes[key] = self._face_planes(*key)
        return self._planes[key]

    def _face_planes(self, max_planes: int, tolerance: float) -> tuple[np.ndarray, np.ndarray] | None:
        if not self.is_convex(tolerance):
            return None
        return self._planes_of(np.arange(len(self.faces)), max_planes, tolerance)

    def _planes_of(self, faces: np.ndarray, max_planes: int, tolerance: float) -> tuple[np.ndarray, np.ndarray] | None:
        """The distinct planes of the faces indexed by ``faces`` and each face's (-1: degenerate or not in ``faces``),
        or None past ``max_planes``."""
        v = self.vertices.astype(np.float64)
        corners = v[self.faces]
        normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        length = np.linalg.norm(normal, axis=1)
        size = float(np.ptp(v, axis=0).max())
        usable = faces[length[faces] > 1e-12 * size * size]
        normal = normal[usable] / length[usable, None]
        offset = np.einsum("ij,ij->i", normal, corners[usable, 0])
        planes, label = np.zeros((max_planes, 4)), np.full(len(self.faces), -1)
        count = 0
        for face, n, w in zip(usable, normal, offset):  # group the faces by plane, giving up past max_planes
            same = np.flatnonzero((planes[:count, :3] @ n > 1.0 - tolerance) & (np.abs(planes[:count, 3] - w) <= tolerance * size))
            if len(same) == 0:
                if count == max_planes:
                    return None
                planes[count] = np.append(n, w)
                same, count = [count], count + 1
            label[face] = same[0]
        return planes[:count], label

    def face_solid(self, max_planes: int, max_quadrics: int, tolerance: float = 1e-4) -> tuple | None:
        """The body the mesh bounds as an intersection of half-spaces and of the insides or outsides of balls and
        round cylinders: (planes (K, 4) as :meth:`face_planes`, their normal fields (K, 3, 4) as
        :meth:`face_plane_normals`, quadrics (Q, 8): centre xyz, a signed radius (+ where the body lies inside: a
        convex face; - outside: a concave one, as a diverging lens's), then a cylinder's unit axis and 1, or zeros for
        a ball). A ray inside leaves the body where it first crosses one of their boundaries. A convex polyhedron
        (:meth:`face_planes`) has no quadrics. Otherwise a face lies on a ball where its corners' normals are the
        ball's (p = c + r n), else on a cylinder where they are a cylinder's (p = c + r n + h u, n . u = 0), when its
        centroid lies within :data:`SPHERE_SAGITTA` of the mesh's size of that surface (fine enough for the surface
        to stand for the facets); the other faces group by plane. None unless the mesh is solid, every vertex lies on
        the body's side of every boundary, and there are at most ``max_planes`` planes and ``max_quadrics``
        quadrics; cached."""
        key = (int(max_planes), int(max_quadrics), float(tolerance), "solid")
        if key not in self._planes:
            self._planes[key] = self._face_solid(max_planes, max_quadrics, tolerance)
        return self._planes[key]

    def _face_solid(self, max_planes: int, max_quadrics: int, tolerance: float) -> tuple | None:
        planes = self.face_planes(max_planes, tolerance)
        if planes is not None:
            fields = self.face_plane_normals(max_planes, tolerance)
            return None if fields is None else (planes, fields, np.zeros((0, 8)))
        if max_quadrics < 1 or not self.is_solid():
            return None
        v, n = self.vertices.astype(np.float64), self.normals.astype(np.float64)
        size = float(np.ptp(v, axis=0).max())
        quadrics, on_quadric = self._face_quadrics(v, n, size, max_quadrics, tolerance)
        if quadrics is None:
            return None
        found = self._planes_of(np.flatnonzero(on_quadric < 0), max_planes, tolerance)
        if found is None:
            return None
        planes, label = found
        fields = self._plane_normals(label, len(planes))
        if fields is None:
            return None
        outside = np.concatenate([v @ planes[:, :3].T - planes[:, 3], quadric_excess(quadrics, v)], axis=1)
        return (planes, fields, quadrics) if outside.size == 0 or outside.max() <= tolerance * size else None

    def _face_quadrics(self, v, n, size: float, max_quadrics: int, tolerance: float):
        """(quadrics (Q, 8) as :meth:`face_solid`'s, the quadric of each face (-1: none)), or (None, None) past
        ``max_quadrics`` or where a group's vertices miss their surface. Each face's ball, else cylinder, is fitted
        to its corners; faces whose surfaces agree within 1e-3 of the mesh's size share one, fitted again to all
        their vertices."""
        corners, normals = v[self.faces], n[self.faces]
        pairs = np.stack([np.cross(normals[:, i], normals[:, (i + 1) % 3]) for i in range(3)], axis=1)
        longest = np.linalg.norm(pairs, axis=2).argmax(axis=1)
        axis = pairs[np.arange(len(pairs)), longest]  # a cylinder's: across its two most different normals
        axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-300)
        axis *= np.where(np.take_along_axis(axis, np.abs(axis).argmax(axis=1)[:, None], axis=1) < 0, -1.0, 1.0)
        ball = _round_face_fit(corners, normals, np.zeros_like(axis), size, tolerance)
        centre, signed, fits = _round_face_fit(corners, normals, axis, size, tolerance)
        cylinder = (centre, signed, fits & (np.abs(np.einsum("fij,fj->fi", normals, axis)).max(axis=1) <= 1e-3))
        quadrics, label = [], np.full(len(self.faces), -1)
        for face in np.flatnonzero(ball[2] | cylinder[2]):
            centre, signed, _ = ball if ball[2][face] else cylinder
            along = np.zeros(4) if ball[2][face] else np.append(axis[face], 1.0)
            fit = np.concatenate([centre[face] / size, [signed[face] / size], along])
            same = [k for k, q in enumerate(quadrics) if np.abs(q - fit).max() <= 1e-3]
            if not same:
                if len(quadrics) == max_quadrics:
                    return None, None
                quadrics.append(fit)
                same = [len(quadrics) - 1]
            label[face] = same[0]
        refitted = np.zeros((len(quadrics), 8))
        for k, quadric in enumerate(quadrics):
            corner = np.unique(self.faces[label == k].ravel())
            p, normal, u = v[corner], n[corner], quadric[4:7]
            if quadric[7]:
                u = np.linalg.svd(normal)[2][-1]  # the direction every normal of a cylinder is square to
                u = u if u[np.abs(u).argmax()] > 0 else -u
                if np.abs(normal @ u).max() > 1e-3:
                    return None, None
                p = p - np.outer(p @ u, u)
            # p = c + s n at every vertex (p projected across the axis on a cylinder): least squares in (c, s).
            system = np.concatenate([np.tile(np.eye(3), (len(corner), 1)), normal.reshape(-1, 1)], axis=1)
            fit = np.linalg.lstsq(system, p.reshape(-1), rcond=None)[0]
            if np.abs(system @ fit - p.reshape(-1)).max() > tolerance * size:
                return None, None
            refitted[k] = np.concatenate([fit, u, [quadric[7]]]) if quadric[7] else np.append(fit, np.zeros(4))
        return refitted, label

    def geometry_hash(self) -> str:
        """Like :meth:`content_hash`, plus the normals (for data that depends on them)."""
        import hashlib

        h = hashlib.sha1(self.content_hash().encode())
        h.update(np.ascontiguousarray(self.normals, dtype="<f4").tobytes())
        return h.hexdigest()[:16]

    def transformed(self, world_from_object: np.ndarray) -> "Mesh":
        """This mesh in world space (normals by the inverse transpose)."""
        m = np.asarray(world_from_object, dtype=np.float64)
        v = self.vertices @ m[:3, :3].T + m[:3, 3]
        n = self.normals @ normal_matrix(m).T
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-20)
        mirrored = np.linalg.det(m[:3, :3]) < 0
        faces = self.faces[:, ::-1] if mirrored else self.faces
        tangents = None
        if self.tangents is not None:  # along the surface: by the matrix itself, then square to the new normal
            t = self.tangents[:, :3] @ m[:3, :3].T
            t -= n * np.sum(n * t, axis=1, keepdims=True)
            t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-20)
            tangents = np.c_[t, -self.tangents[:, 3] if mirrored else self.tangents[:, 3]]
        return Mesh(v, n, faces, name=self.name, uvs=self.uvs, tangents=tangents)


TANGENT_HANDEDNESS_TOLERANCE = 1e-3  # a tangent's w must be +-1 within this (quantized files round it)


def _checked_tangents(value, count: int, label: str) -> np.ndarray:
    """(N, 4) float32 tangents: ``count`` finite rows whose w is +-1 (within the tolerance; stored as exactly
    +-1); MeshError otherwise."""
    tangents = _numeric(value, label, "tangents")
    if tangents.shape != (count, 4) or not np.all(np.isfinite(tangents)) \
            or not np.all(np.abs(np.abs(tangents[:, 3]) - 1.0) <= TANGENT_HANDEDNESS_TOLERANCE):
        raise MeshError(f"{label} has invalid tangents (shape {short(tangents.shape)} for {count} vertices; each "
                        "must be four finite numbers with w = +1 or -1); drop them so caustica generates them")
    if tangents.dtype == np.float32 and np.all(np.abs(tangents[:, 3]) == 1.0):
        return np.ascontiguousarray(tangents)  # already checked: kept as the very array
    tangents = np.array(tangents, dtype=np.float32)
    tangents[:, 3] = np.where(tangents[:, 3] < 0, -1.0, 1.0)
    return tangents


def quadric_excess(quadrics: np.ndarray, points: np.ndarray) -> np.ndarray:
    """How far each point (N, 3) lies beyond each quadric of :meth:`Mesh.face_solid` (N, Q): its distance from
    a ball's centre or a cylinder's axis less the radius, negated for the outside of one (a concave face)."""
    offset = points[:, None, :] - quadrics[None, :, :3]
    across = offset - quadrics[None, :, 7:8] * np.einsum("nqi,qi->nq", offset, quadrics[:, 4:7])[..., None] * quadrics[None, :, 4:7]
    return (np.linalg.norm(across, axis=2) - np.abs(quadrics[:, 3])) * np.sign(quadrics[:, 3])


def _round_face_fit(corners: np.ndarray, normals: np.ndarray, axis: np.ndarray, size: float, tolerance: float):
    """Each face's ball (``axis`` zero) or cylinder about ``axis`` from its corners (F, 3, 3) and their normals:
    (centre (F, 3), signed radius s (F,), whether it fits): p = c + s n with p projected across the axis; it fits
    where every corner lies within ``tolerance`` and the centroid within SPHERE_SAGITTA of the mesh's size of it."""
    along = np.einsum("fij,fj->fi", corners, axis)[..., None] * axis[:, None, :]
    projected = corners - along
    dp = projected - projected.mean(axis=1, keepdims=True)
    dn = normals - normals.mean(axis=1, keepdims=True)
    spread = np.einsum("fij,fij->f", dn, dn)
    signed = np.einsum("fij,fij->f", dp, dn) / np.maximum(spread, 1e-30)
    centre = (projected - signed[:, None, None] * normals).mean(axis=1)
    miss = np.linalg.norm(projected - signed[:, None, None] * normals - centre[:, None], axis=2).max(axis=1)
    sagitta = np.abs(np.linalg.norm(projected.mean(axis=1) - centre, axis=1) - np.abs(signed))
    fits = ((spread > 1e-10) & (np.abs(signed) > tolerance * size) & (miss <= tolerance * size)
            & (sagitta <= SPHERE_SAGITTA * size))
    return centre, signed, fits


def _numeric(value, label: str, what: str) -> np.ndarray:
    """``value`` as a numeric numpy array (not converted further), or MeshError."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        array = None
    if array is None or not (np.issubdtype(array.dtype, np.number) and not np.issubdtype(array.dtype, np.complexfloating)):
        raise MeshError(f"{label} {what} must be an array of numbers (got {short(value)})")
    return array


def check_faces(faces: np.ndarray, vertex_count: int, label: str) -> None:
    """MeshError unless ``faces`` is (M, 3) integers indexing ``vertex_count`` vertices, 1 <= M <= MAX_TRIANGLES."""
    if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
        raise MeshError(f"{label} has no triangles; give a mesh with at least one triangle")
    rules.triangles(len(faces), f"{label} has", "use a coarser (decimated) mesh", error=MeshError)
    if not np.issubdtype(faces.dtype, np.integer) or faces.min() < 0 or faces.max() >= vertex_count:
        raise MeshError(f"{label} has face indices out of range; repair the mesh file")


def check_positions(vertices: np.ndarray, label: str) -> np.ndarray:
    """The (2, 3) bounds of ``vertices``; MeshError unless every coordinate is finite and within
    +-rules.MAX_COORDINATE (min and max propagate NaN; per column, which is faster than axis=0 on (N, 3))."""
    if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) == 0:
        raise MeshError(f"{label} has no vertices of three coordinates; give a mesh with at least one triangle")
    bounds = np.array([[vertices[:, k].min() for k in range(3)], [vertices[:, k].max() for k in range(3)]])
    if not np.all(np.isfinite(bounds)):
        raise MeshError(f"{label} has NaN or infinite vertex positions; repair the mesh file")
    largest = float(np.abs(bounds).max())
    if largest > rules.MAX_COORDINATE:
        raise MeshError(f"{label} has vertex coordinates up to {largest:.3g}, beyond +-{rules.MAX_COORDINATE:g}; "
                        "rescale the mesh (e.g. to metres) and use the object's scale")
    return bounds


def split_at_midpoints(faces: np.ndarray, vertex_count: int, selected: np.ndarray | None = None):
    """(edges (E, 2), faces): each ``selected`` face (default every one) split into four at its edges'
    midpoints, a midpoint shared by the faces that share its edge; new vertex ``vertex_count + k`` is the
    midpoint of ``edges[k]``, whose attributes the caller computes. Unselected faces come first, unchanged."""
    faces = np.asarray(faces)
    chosen = faces if selected is None else faces[selected]
    ends = np.sort(chosen[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges, edge_of = np.unique(ends, axis=0, return_inverse=True)
    mid = vertex_count + edge_of.reshape(-1, 3)
    a, b, c = chosen.T
    ab, bc, ca = mid.T
    kept = faces[:0] if selected is None else faces[~selected]
    split = [np.stack(f, axis=1) for f in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))]
    return edges, np.concatenate([kept, *split]).astype(faces.dtype)


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted smooth vertex normals."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    face_n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, f[:, k], face_n)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(length > 1e-30, n / np.maximum(length, 1e-30), np.array([0.0, 1.0, 0.0]))
    return n.astype(np.float32)
