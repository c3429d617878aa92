"""The casters of caustics (glass and mirrors) and the code that says what each does to light.

caustic-mapping's caster table (``caustic_trace.comp``'s ``caster_type``) and photon-splats' object kind
(``photon_refract.frag``'s ``object_kind``) hold the ``CASTER_*`` codes of :mod:`caustica.scene.codes`,
which the shader library defines in every program.
"""
from __future__ import annotations

from ..scene.codes import CASTER_MIRROR, CASTER_NONE, CASTER_SOLID, CASTER_SURFACE

__all__ = ["MAX_CASTERS", "CASTER_NONE", "CASTER_MIRROR", "CASTER_SOLID", "CASTER_SURFACE", "casters", "caster_code"]

MAX_CASTERS = 32

def casters(scene) -> list:
    """The objects that make caustics (glass and mirrors), at most MAX_CASTERS, in scene order."""
    return [o for o in scene.objects if o.material.kind in ("glass", "mirror")][:MAX_CASTERS]


def caster_code(obj) -> int:
    """What the caustic passes do with an object's light (an open glass mesh is a single surface)."""
    kind = obj.material.kind
    if kind == "mirror":
        return CASTER_MIRROR
    if kind == "glass":
        return CASTER_SURFACE if obj.mesh.is_open() else CASTER_SOLID
    return CASTER_NONE
