"""What ``auto``'s rules measure on a scene with exact rays (Embree) and its meshes: the internal bounces that carry
light (Hu and Qin 2.1), whether caustics land and how many glass interfaces their light crosses (Shah et al. 3.1,
Iwasaki et al. 4), the sky's occlusion on diffuse surfaces (the environment's lobes and light maps), and where
per-vertex's least-squares viewpoint fails on a mirror (Kakimoto et al. 3.2). What is traced is cached on the scene
by its state.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..cache import kept_on, material_state_key, scene_state_key, state_key
from ..lighting.environment import lobe_occlusion, scene_floor


def lit_lights(scene) -> list:
    """The scene's lights that shine (some intensity above 0)."""
    return [light for light in scene.lights if np.any(np.asarray(light.intensity) > 0)]


def sheds_light(environment) -> bool:
    """Whether the environment sheds any light (its SH irradiance's constant term above 0 in some channel)."""
    return bool(np.any(environment.irradiance_sh()[0] > 0))


# The lobes pay where objects block more than this share of the sky on diffuse surfaces (docs/auto.md, the lobes).
LOBE_SHARE = 1e-2


def occluded_ambient(scene) -> bool:
    """Whether the environment lobes' shadows pay: diffuse surfaces with another object to occlude their
    environment light, an environment that sheds some, and no lights of the scene's own (where the scene has
    lights, the sky's share of the diffuse light is too small to pay), and a floor (whose bounce the lobes bring)
    or objects that block more than LOBE_SHARE of the sky on the diffuse surfaces (lobe_occlusion: exact rays
    towards each lobe). The measurements behind the rule: docs/auto.md and docs/environment-light.md."""
    diffuse = [o for o in scene.objects if o.material.kind == "diffuse"]
    return (bool(diffuse) and len(scene.objects) > 1 and not scene.lights
            and sheds_light(scene.environment)
            and (scene_floor(scene) is not None or lobe_occlusion(scene) > LOBE_SHARE))


def baked_receivers(scene) -> bool:
    """Whether the light maps pay (environment_lights.bake_plan: the floor, box faces, planes, curved receivers per
    vertex): a diffuse object and another object, under an environment that sheds some light, with a floor (which
    the others shadow or the sky's caustic lights) or, without one, objects that take more than LOBE_SHARE of the
    sky's light on the diffuse faces the camera sees (lobe_occlusion; below it the unoccluded SH is kept); in any
    environment, where a light shines through glass onto a floor (:func:`_bounced_through_glass`)."""
    return (len(scene.objects) > 1 and any(o.material.kind == "diffuse" for o in scene.objects)
            and sheds_light(scene.environment)
            and (scene_floor(scene) is not None or lobe_occlusion(scene) > LOBE_SHARE)) or _bounced_through_glass(scene)


def _bounced_through_glass(scene) -> bool:
    """Whether a light of the scene shines through glass onto a floor (of PLAN_PHOTONS photons, CAUSTIC_SHARE at
    least of the flux lands: caustic_paths): then the floor's own diffuse light comes back to it through the
    glass, which no raster pass carries and the light maps' one bounce does (raytrace/environment_bake.py),
    even in a black environment (docs/auto.md, "The floor's light back through the glass")."""
    lit = lit_lights(scene)
    return (bool(lit) and scene_floor(scene) is not None and any(o.material.kind == "glass" for o in scene.objects)
            and caustic_paths(scene, lit).landed)


BOUNCE_VIEW = (64, 48)  # the camera's pixels at which the exact paths measure the bounces' shares


def bounces_that_pay(scene, bounces: int, least: float) -> tuple[int, int]:
    """(bounces followed, bounces left out): the most internal bounces, up to ``bounces``, whose last carries
    at least ``least`` (BOUNCE_SHARE) of the light that enters the glass at the camera's glass pixels
    (raytrace/paths.exit_shares: Fresnel-weighted exact paths, Embree; Hu and Qin 2.1's bounces inside the
    object). Where no light leaves through a glass exit (a water sheet: the refracted light lands on the floor,
    and the shader finds no exit to bounce from) none is followed; with no glass pixel in view, all. Cached on
    the scene by its state and camera. What a bounce carries and costs on the presets: docs/auto.md."""
    from ..raytrace.paths import exit_shares

    if bounces <= 0 or least <= 0.0:
        return bounces, 0
    def weighed() -> tuple[int, int]:
        shares = exit_shares(scene, scene.camera.with_size(*BOUNCE_VIEW), bounces + 1)
        if np.isnan(shares).any():  # no glass pixel in view: nothing to weigh
            return bounces, 0
        total = float(shares.sum())
        paying = [k for k in range(1, bounces + 1) if shares[k] > 0.0 and shares[k] >= least * total]
        followed = max(paying, default=0)
        return followed, bounces - followed

    key = (scene_state_key(scene), material_state_key(scene), scene.camera._state(), int(bounces), float(least))
    return kept_on(scene, "_bounce_cache", key, weighed)


PLAN_PHOTONS = 4096  # photons that decide whether a light's caustic reaches a diffuse surface at all
# The least share of the flux the lights send towards the casters that must land on diffuse surfaces as caustics
# for a caustic map to pay (docs/auto.md, caustic mapping: below it the map changed no pixel).
CAUSTIC_SHARE = 1e-2


@dataclass(frozen=True)
class CausticPaths:
    """What PLAN_PHOTONS exact photons say of a scene's caustics (:func:`caustic_paths`)."""

    landed: bool  # CAUSTIC_SHARE at least of the flux sent towards the casters reached a diffuse surface
    beyond_two: float  # the share of the landed flux that crossed other than two glass interfaces
    share: float = 0.0  # the landed flux over the flux sent towards the casters


def caustic_paths(scene, lit: list) -> CausticPaths:
    """PLAN_PHOTONS photons from the ``lit`` lights (the environment's sun among them), refracted through the
    glass and reflected off the mirrors (``branches="transmit"``: glass reflects only on TIR, as in caustic
    mapping), traced to the diffuse surfaces (raytrace/photons.py, Embree). Where none lands, or less than
    CAUSTIC_SHARE of the flux sent towards the casters, a caustic map would cost every frame and add no light.
    The share of the landed flux on other than two interfaces (one through a scan's hole, three or four through a
    second lobe, internal reflections) is what caustic mapping's two-interface estimate (Shah et al. 3.1) misses
    and a transport table (Iwasaki et al. 4) follows. Cached on the scene by its state."""
    from dataclasses import replace

    from ..raytrace.photons import trace_photons

    def traced() -> CausticPaths:
        hits = trace_photons(replace(scene, lights=list(lit)), count=PLAN_PHOTONS, max_depth=8, branches="transmit")
        flux = hits.flux.sum(axis=1)
        total = float(flux.sum())
        beyond = float(flux[hits.bounces != 2].sum()) / total if total > 0 else 0.0
        share = total / max(float(hits.emitted.sum()), 1e-300)
        return CausticPaths(bool(len(hits.position)) and share >= CAUSTIC_SHARE, beyond, share)

    key = (scene_state_key(scene), material_state_key(scene), tuple(state_key(light) for light in lit))
    return kept_on(scene, "_caustic_paths_cache", key, traced)


CONCAVE = 0.25  # a mirror is concave when this fraction of its surface bends towards the camera
# Per-vertex pays while its least-squares viewpoint sees the mirror's hits within this many degrees of the reflected
# rays on average (per_vertex.viewpoint_parallax; Kakimoto et al. 3.2); above it impostors is ahead (the presets'
# angles and scores: docs/auto.md). No hysteresis: the plan is a function of the scene's state and camera, so that
# batch workers rendering frames in any order plan alike (docs/determinism.md).
PARALLAX = 0.3
NESTED = 0.01  # a mirror whose vertices' rays meet another mirror this often keeps per-vertex (Kakimoto et al. 4.4)


def per_vertex_fails(mirrors: list, scene) -> str:
    """Why per-vertex would fail on these mirrors, in words, or '' where it serves: a concave mirror
    (:func:`_concave`) focuses the reflected rays; a mirror whose rays pass far from one viewpoint (above
    PARALLAX: :func:`_mirror_rays`) is seen from it with the nearby objects shifted, unless one of the mirrors
    shows another (NESTED): per-vertex renders a mirror in a mirror exact at its vertices level by level (4.4),
    where impostors' recursive textures are distorted (Hu and Qin 2.2.1)."""
    if hollow := [o.name for o in mirrors if _concave(o, scene.camera)]:
        return f"a concave mirror ({', '.join(hollow)}) focuses the reflected rays"
    rays = _mirror_rays(mirrors, scene)
    if any(nested >= NESTED for _, nested in rays):
        return ""
    astray = {o.name: angle for o, (angle, _) in zip(mirrors, rays) if angle > PARALLAX}
    if astray:
        angles = ", ".join(f"{name} {angle:.2f}" for name, angle in astray.items())
        return (f"the reflected rays pass far from one viewpoint ({angles} degrees, the mean angle between a "
                f"vertex's ray and its hit seen from the least-squares viewpoint, above {PARALLAX:g}: Kakimoto et "
                "al. 3.2, 6)")
    return ""


def _mirror_rays(mirrors: list, scene) -> list[tuple[float, float]]:
    """Per mirror, (its :func:`~caustica.per_vertex.viewpoint.viewpoint_parallax`, the share of its vertices' rays
    that meet another mirror): the eye's rays reflected at its vertices (as per-vertex issues them, Kakimoto et
    al. 3.1), traced by Embree. Cached on the scene by its state and camera."""
    from ..per_vertex.rays import reflection_rays, trace_lines
    from ..per_vertex.viewpoint import viewpoint_parallax
    from ..raytrace.embree_scene import ray_scene_for

    def traced() -> list[tuple[float, float]]:
        eye, ray_scene = np.asarray(scene.camera.position, np.float64), ray_scene_for(scene)
        mirror = np.array([o.material.kind == "mirror" for o in scene.objects] + [False])  # [-1]: no hit
        out = []
        for obj in mirrors:
            mesh = obj.world_mesh()
            lines, hits = trace_lines(ray_scene, *reflection_rays(eye, mesh.vertices.astype(np.float64),
                                                                  mesh.normals.astype(np.float64)))
            index = np.where(hits.hit, hits.object_index, -1)
            out.append((viewpoint_parallax(lines), float(mirror[index].mean()) if len(index) else 0.0))
        return out

    key = (scene_state_key(scene), scene.camera._state(), tuple(id(o) for o in mirrors))
    return kept_on(scene, "_mirror_rays_cache", key, traced)


def _concave(obj, camera) -> bool:
    """Whether the mirror bends towards the camera on at least CONCAVE of its surface (Mesh.concave_fraction):
    per-vertex was made for convex and flat mirrors (Kakimoto et al.: car mirrors)."""
    return obj.world_mesh().concave_fraction(camera.position) >= CONCAVE
