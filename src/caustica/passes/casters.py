"""The casters of caustics (glass and mirrors) and the codes that say what each does to light.

One table for Python and the shaders: ``caustic-mapping``'s caster table (``caustic_trace.comp``'s
``caster_type``) and ``photon-splats``' object kind (``photon_refract.frag``'s ``object_kind``) hold
these codes, and the shaders get their names as defines (:data:`CASTER_DEFINES`).
"""
from __future__ import annotations

MAX_CASTERS = 32
CASTER_NONE = 0  # not a caster: occludes the light
CASTER_MIRROR = 1  # reflects once
CASTER_SOLID = 2  # closed glass: refracts in, and out through the back faces
CASTER_SURFACE = 3  # open glass mesh (water): one refracting surface
CASTER_DEFINES = {"CASTER_NONE": CASTER_NONE, "CASTER_MIRROR": CASTER_MIRROR,
                  "CASTER_SOLID": CASTER_SOLID, "CASTER_SURFACE": CASTER_SURFACE}


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
