"""Per-vertex tangent frames for normal maps (glTF 2.0's TANGENT: xyz and a handedness w of +-1).

A file's own tangents are used as given; otherwise they are generated the way MikkTSpace does for welded
smooth meshes: each triangle's uv-aligned tangent and bitangent, weighted by the corner angle, summed per
vertex, made orthogonal to the vertex normal (Gram-Schmidt), with w the sign of the frame's handedness.
Pure numpy.
"""
from __future__ import annotations

import numpy as np


def vertex_tangents(vertices: np.ndarray, normals: np.ndarray, uvs: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(N, 4) float32 tangents: xyz unit length, orthogonal to ``normals``, along +u; w = +-1 such that
    w * cross(normal, tangent) is the bitangent, which points up the image (-v: v grows down the image in
    glTF's and caustica's uvs), where a normal map's green channel points."""
    p = np.asarray(vertices, np.float64)
    n = np.asarray(normals, np.float64)
    uv = np.asarray(uvs, np.float64)
    faces = np.asarray(faces, np.int64)
    tangent = np.zeros_like(p)
    bitangent = np.zeros_like(p)
    for corner in range(3):
        a, b, c = faces[:, corner], faces[:, (corner + 1) % 3], faces[:, (corner + 2) % 3]
        e1, e2 = p[b] - p[a], p[c] - p[a]
        d1, d2 = uv[b] - uv[a], uv[c] - uv[a]
        det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
        sign = np.where(det < 0, -1.0, 1.0)
        safe = np.where(np.abs(det) > 1e-20, det, sign * 1e-20)
        t = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) / safe[:, None]
        s = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) / safe[:, None]
        # MikkTSpace weights each corner by its angle, and by the uv area's sign only through the direction.
        cos = np.sum(e1 * e2, axis=1) / np.maximum(np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1), 1e-30)
        angle = np.arccos(np.clip(cos, -1.0, 1.0))
        t = t / np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-30)
        s = s / np.maximum(np.linalg.norm(s, axis=1, keepdims=True), 1e-30)
        np.add.at(tangent, a, t * angle[:, None])
        np.add.at(bitangent, a, s * angle[:, None])
    tangent -= n * np.sum(n * tangent, axis=1, keepdims=True)
    length = np.linalg.norm(tangent, axis=1, keepdims=True)
    # A vertex without uv variation (or a degenerate chart) takes any unit vector orthogonal to its normal.
    fallback = np.cross(n, np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    fallback /= np.maximum(np.linalg.norm(fallback, axis=1, keepdims=True), 1e-30)
    tangent = np.where(length > 1e-12, tangent / np.maximum(length, 1e-30), fallback)
    w = np.where(np.sum(np.cross(n, tangent) * -bitangent, axis=1) < 0.0, -1.0, 1.0)
    return np.ascontiguousarray(np.c_[tangent, w], dtype=np.float32)


def mesh_tangents(mesh) -> np.ndarray | None:
    """The mesh's tangent frames (N, 4): the file's own (``mesh.tangents``) where it has them, else generated
    from its uvs and kept on the mesh for its vertices, normals, uvs and faces; None without uvs."""
    given = getattr(mesh, "tangents", None)
    if given is not None:
        return given
    if mesh.uvs is None:
        return None
    key = (mesh.vertices, mesh.normals, mesh.uvs, mesh.faces)
    cached = getattr(mesh, "_generated_tangents", None)
    if cached is None or any(a is not b for a, b in zip(cached[0], key)):
        cached = (key, vertex_tangents(mesh.vertices, mesh.normals, mesh.uvs, mesh.faces))
        mesh._generated_tangents = cached
    return cached[1]
