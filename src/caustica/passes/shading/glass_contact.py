"""Glass standing on a diffuse surface: depth-search's exits through a face that lies on it (ours).

Hu and Qin (TVCG 2007, 2.1.4) leave the glass at its exit P2 along the refracted T2 with the share 1 - F, and our
internal bounces send the share F (all of it past the critical angle) on inside. A clear cube resting on a floor has
its bottom face in the floor's plane: no air lies between glass and floor there, so the light that reaches that face
lands on the floor at P2, all of it, and none is reflected back, as in the light maps' rays
(raytrace/environment_bake.py, which leave such faces out).

:func:`contact_plane` is the receiver's plane that a glass object stands on
(``raytrace.environment_bake.standing_plane``); the shader (``depth_search.frag``, GLASS_CONTACT) takes an exit
within ``contact_tolerance`` of it through a face turned into it as landing there: the nearby lookup straight into
the receiver from the exit point put on its plane, weight 1, and the path ends. From the light the same holds
(:func:`bind_caster_contacts`, ``caustic_trace.comp``): caustic mapping's photon (Shah et al. III-C) that reaches
such a face, at once or after internal reflections, lands at its exit with the flux it carries instead of leaving
the glass below the receiver's plane.
Photon splats (Wyman, ``photon_refract.frag``) land a photon whose exit face seen from the light lies on the plane
where T1 meets it, with no exit Fresnel; the transport table (Iwasaki et al.) traces the glass without those faces
(``raytrace.environment_bake.without_standing_faces``), so its rays leave through the opening into the receiver.
The shaders share the test, ``common/glass_contact.glsl``.
"""
from __future__ import annotations

import numpy as np

from ...cache import LruCache
from ...gpu.meshes import set_uniform, write_uniform_array
from ...raytrace.environment_bake import contact_tolerance, standing_key, standing_plane

PLANES_KEPT = 8  # scene states kept: a frame's impostor views draw scenes of their own
_PLANES = LruCache(PLANES_KEPT)  # standing_key -> ((4,) plane or None per object)


def contact_plane(scene, obj) -> np.ndarray | None:
    """(4,) float32 :func:`~caustica.raytrace.environment_bake.standing_plane` of ``obj`` in ``scene``, kept per
    geometry (standing_key); None where it stands on nothing."""
    key = standing_key(scene)
    planes = _PLANES.get(key)
    if planes is None:
        planes = _PLANES[key] = [standing_plane(scene, o) if o.material.kind == "glass" else None
                                 for o in scene.objects]
    plane = next((plane for o, plane in zip(scene.objects, planes) if o is obj), None)
    return None if plane is None else plane.astype(np.float32)


def contact_defines(frame) -> dict:
    """GLASS_CONTACT 1 where some glass object of the frame stands on a receiver, else 0 (the shader unchanged)."""
    return {"GLASS_CONTACT": int(any(contact_plane(frame.scene, o) is not None
                                     for o in frame.scene.objects_of("glass")))}


def glass_contact(scene, obj) -> tuple[np.ndarray, float]:
    """(contact plane (4,), contact tolerance) of ``obj`` in ``scene``; a zero plane and 0 where it is no glass
    standing on a receiver."""
    plane = contact_plane(scene, obj) if obj.material.kind == "glass" else None
    if plane is None:
        return np.zeros(4, np.float32), 0.0
    return plane, contact_tolerance(obj.world_mesh().bounds)


def bind_contact_plane(program, scene, obj) -> None:
    """Set the shader's contact_plane (n = 0: none) and contact_tolerance for ``obj``."""
    plane, tolerance = glass_contact(scene, obj)
    set_uniform(program, "contact_plane", plane)
    if plane.any():
        set_uniform(program, "contact_tolerance", tolerance)


def bind_caster_contacts(program, scene, objects: list, size: int) -> None:
    """Set ``contact_plane[size]`` (n = 0: none) and ``contact_tolerance[size]`` for the casters ``objects``."""
    planes, tolerances = np.zeros((size, 4), np.float32), np.zeros(size, np.float32)
    for i, obj in enumerate(objects[:size]):
        planes[i], tolerances[i] = glass_contact(scene, obj)
    write_uniform_array(program, "contact_plane", planes)
    write_uniform_array(program, "contact_tolerance", tolerances)
