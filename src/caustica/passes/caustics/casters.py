"""The casters of caustics (glass and mirrors) and the code that says what each does to light.

caustic-mapping's caster table (``caustic_trace.comp``'s ``caster_type``) and photon-splats' object kind
(``photon_refract.frag``'s ``object_kind``) hold the ``CASTER_*`` codes of :mod:`caustica.scene.codes`,
which the shader library defines in every program.
"""
from __future__ import annotations

import numpy as np

from ...cache import LruCache
from ...scene.codes import CASTER_MIRROR, CASTER_NONE, CASTER_SOLID, CASTER_SURFACE

__all__ = ["MAX_CASTERS", "CASTER_NONE", "CASTER_MIRROR", "CASTER_SOLID", "CASTER_SURFACE", "casters", "caster_code",
           "nearly_closed", "length_unit", "half_diagonal"]

MAX_CASTERS = 32
# A glass mesh with holes whose net vector area is under this fraction of its area is a solid to the photons.
NEARLY_CLOSED = 0.05
_NEARLY_CLOSED = LruCache(256)  # mesh content hash -> nearly_closed

def casters(scene) -> list:
    """The objects that make caustics (glass and mirrors), at most MAX_CASTERS, in scene order."""
    return [o for o in scene.objects if o.material.kind in ("glass", "mirror")][:MAX_CASTERS]


def half_diagonal(objects) -> float:
    """Half the diagonal of the objects' joint world bounding box (0 for none)."""
    if not objects:
        return 0.0
    boxes = np.stack([o.world_mesh().bounds for o in objects])
    return float(0.5 * np.linalg.norm(boxes[:, 1].max(axis=0) - boxes[:, 0].min(axis=0)))


def length_unit(scene) -> float:
    """The casters' bounding radius (the scene's without casters), the photon shaders' ``length_unit``:
    their surface offsets and convergence tolerances are fractions of it, so that they scale with the casters
    (an absolute offset would swallow a tiny ball's caustic)."""
    return half_diagonal(casters(scene)) or half_diagonal(scene.objects) or 1.0


def caster_code(obj) -> int:
    """What the caustic passes do with an object's light: a glass mesh is a solid (front faces in, back
    faces out) unless it is open beyond small holes (:func:`nearly_closed`), then a single surface (water).
    Small holes keep a scanned solid (the Stanford bunny) a solid: as a single surface its photons would
    refract once and run on inside the "glass" to the floor."""
    kind = obj.material.kind
    if kind == "mirror":
        return CASTER_MIRROR
    if kind == "glass":
        return CASTER_SURFACE if obj.mesh.is_open() and not nearly_closed(obj.mesh) else CASTER_SOLID
    return CASTER_NONE


def nearly_closed(mesh) -> bool:
    """Whether a mesh's holes are small: its net vector area |sum of n_i A_i| (zero for a closed mesh,
    about the holes' area, capped, for one with holes; the whole area for a sheet) is under NEARLY_CLOSED
    of its area. Scanned models keep small holes: the Stanford bunny (223 open edges at its base) has 0.017,
    a water surface 0.98. Cached per geometry."""
    key = mesh.content_hash()
    if key not in _NEARLY_CLOSED:
        v = np.asarray(mesh.vertices, np.float64)
        f = np.asarray(mesh.faces)
        cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        area = float(np.linalg.norm(cross, axis=1).sum())
        _NEARLY_CLOSED[key] = area > 0.0 and float(np.linalg.norm(cross.sum(axis=0))) < NEARLY_CLOSED * area
    return _NEARLY_CLOSED[key]
