"""``auto``: the most accurate real-time combination for the scene at hand, planned from its contents.

The plan (:func:`plan`) looks at what the scene holds and picks, with the reason, the
technique each part needs; docs/auto.md gives the table and the measurements behind it:

- glass with other objects in the scene: ``impostors`` (Hu and Qin 2.2), so refracted and
  reflected rays see the nearby geometry, with depth-search's exit routine and internal bounces;
- glass alone in the environment: ``depth-search`` with internal bounces (Hu and Qin 2.1);
- mirrors without glass: ``per-vertex`` (Kakimoto et al.: exact at every vertex, and exact for a
  flat mirror, whose least-squares viewpoint is its mirror image); a concave mirror, which focuses
  the reflected rays, and one whose rays pass far from one viewpoint (a cylinder, a saddle: PARALLAX)
  take ``impostors`` instead, unless a mirror shows another (NESTED);
- glass of IOR 1 that absorbs nothing: left out (``drop_invisible_glass``), the plan made without it;
- nothing specular: ``env-map`` (diffuse shading with shadow maps);
- lights whose light reaches diffuse receivers through or off glass and mirrors: ``caustic-mapping``
  (Shah et al.) is composed with the view technique, or ``transport-table`` (Iwasaki et al.) where
  every caster is solid glass, not all convex, and more than 5 % of the caustic light crosses other
  than two glass interfaces (TABLE_SHARE), its rays traced for the light's own directions
  (``exit_rays="traced"``: no table is cached or needed), its photons set by the quality;
- light maps of the diffuse receivers (the environment's light, occluded and through glass, one bounce) where
  objects occlude an environment that sheds light, and in any environment where a light shines through glass
  onto a floor (the floor's own light comes back through the glass).

``quality`` sets the parameters the costs depend on (internal bounces, impostor and map sizes, the table's
photons);
``budget_ms`` instead takes the highest quality whose frame time, measured on this device at this
size and cached on disk (``$CAUSTICA_CACHE/costs``), fits the budget.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

import numpy as np

from ..cache import kept_on, material_state_key, scene_state_key, state_key
from ..errors import TechniqueError
from ..lighting.bake import MAX_BAKE_SIZE, bake_plan
from ..lighting.environment import LOBES, MAX_LOBES, environment_sun, lobe_occlusion, scene_floor
from ..passes.shading.convex_exits import convex_shape
from ..raytrace.environment_bake import BAKE_SIZE, FACE_SIZE, VERTEX_CAP
from ..scene.gltf.origin import thin_walled_glass, thin_walled_note
from ..scene.scene import invisible_objects, without_invisible_glass
from .base import Params, Technique, param
from .registry import get_technique

QUALITY = {  # quality -> (internal bounces, impostor texels, caustic-map texels, shadow-map texels, table photons)
    "draft": (0, 256, 256, 512, 1 << 16),
    "balanced": (2, 512, 512, 1024, 1 << 17),
    "high": (4, 1024, 1024, 2048, 1 << 18),
}
CAUSTICS = "caustic-mapping"
MIN_CAUSTIC_MAP = 256  # the smallest caustic map auto plans (caustic_map_size)
TABLE = "transport-table"  # the caustics where every caster is solid glass whose light crosses it more than twice


@dataclass
class AutoParams(Params):
    """Parameters of ``auto``."""

    quality: str = param("balanced", choices=tuple(QUALITY),
                         help="draft (fastest), balanced, or high (more internal bounces, larger maps); "
                              "any other parameter goes to the planned technique")
    budget_ms: float = param(0.0, range=(0.0, 1e6), special={0: "none: quality decides"}, unit="ms",
                             help="frame-time budget: the highest quality whose measured frame time fits")
    environment_lobes: int = param(LOBES, range=(0, MAX_LOBES), special={0: "none: unoccluded SH ambient"},
                                   help="the environment's strata of equal power whose light on diffuse surfaces is "
                                        "shadowed (one directional shadow map each; docs/environment-light.md), "
                                        "where the plan finds diffuse surfaces that other objects occlude")
    environment_bake: int = param(BAKE_SIZE, range=(0, MAX_BAKE_SIZE), special={0: "none"}, unit="texels",
                                  help="texels a side of the floor's light map of the environment's light (box "
                                       "faces get 16, planes up to this, curved receivers per vertex), baked once "
                                       "per scene state with exact's rays (occlusion, glass, the sky's caustic, one "
                                       "bounce; docs/environment-light.md), where objects occlude diffuse receivers")


@dataclass
class PlanEntry:
    """What renders one object, and why."""

    object: str
    kind: str  # the object's material kind
    handled_by: str
    reason: str


@dataclass
class Plan:
    """The technique ``auto`` runs for a scene, its parameters, and each object's part in it."""

    technique: str
    params: dict
    quality: str
    objects: list[PlanEntry] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def describe(self) -> str:
        """The plan as readable lines."""
        params = ", ".join(f"{k}={v}" for k, v in self.params.items()) or "defaults"
        lines = [f"technique: {self.technique} ({params}; quality {self.quality})"]
        for entry in self.objects:
            lines.append(f"  {entry.object} ({entry.kind}): {entry.handled_by}: {entry.reason}")
        lines.extend(f"  note: {note}" for note in self.notes)
        return "\n".join(lines)

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=2)


def caustic_map_size(quality_size: int, frame_size) -> int:
    """The caustic map's texels a side for a frame of ``frame_size`` (width, height) pixels, supersampled:
    twice the frame's longer side rounded up to a power of two, at least 256 and at most the quality's size.
    Measured (docs/auto.md, "Caustic maps follow the frame"): at 128^2 a 256 map is as close to exact's
    caustic as a 512 one, at 256^2 the 512 map is needed; a map rebuild costs in proportion to its texels."""
    wanted = 1 << int(np.ceil(np.log2(max(2 * max(frame_size), 1))))
    return int(min(quality_size, max(MIN_CAUSTIC_MAP, wanted)))


def plan(scene, quality: str = "balanced", frame_size=None) -> Plan:
    """The technique and parameters ``auto`` uses for ``scene`` at ``quality``, with the reasons;
    ``frame_size``: the (supersampled) pixels the frame renders, default the scene camera's size."""
    if quality not in QUALITY:
        from ..errors import closest_name

        raise TechniqueError(f"unknown quality {quality!r}{closest_name(str(quality), QUALITY)}; "
                             f"use one of {', '.join(QUALITY)}")
    if not invisible_objects(scene):
        return _plan_visible(scene, quality, frame_size)
    visible = without_invisible_glass(scene)
    chosen = _plan_visible(visible, quality, frame_size)
    chosen.params["drop_invisible_glass"] = True
    planned = {id(o): entry for o, entry in zip(visible.objects, chosen.objects)}
    chosen.objects = [planned.get(id(o)) or PlanEntry(o.name, o.material.kind, "left out", INVISIBLE)
                      for o in scene.objects]
    return chosen


INVISIBLE = ("IOR 1 and no absorption: it neither reflects (Fresnel 0), bends nor tints light, so a path tracer "
             "renders it as air (Hu and Qin fig. 18); left out of every pass (drop_invisible_glass): no glass "
             "pixels, no shadow or caustic, hides nothing from the other objects' impostors, light maps and "
             "shadow maps, and the plan is made for the scene without it")


def _exits_of(glass) -> str:
    """How depth-search finds a glass object's exits under auto (convex_exits)."""
    shape = convex_shape(glass)
    if shape is None:
        return "exits by depth search (Hu and Qin 2.1)"
    cylinders = int(shape.quadrics[:, 7].sum())
    counts = ((len(shape.planes), "plane"), (len(shape.quadrics) - cylinders, "sphere"), (cylinders, "cylinder"))
    faces = " and ".join(f"{count} {name}{'' if count == 1 else 's'}" for count, name in counts if count)
    return f"exits computed exactly on its {faces} (ours, passes/shading/convex_exits.py)"


def _plan_visible(scene, quality: str, frame_size) -> Plan:
    """:func:`plan` for a scene without invisible glass."""
    bounces, impostor_size, map_size, shadow_size, table_photons = QUALITY[quality]
    objects = list(scene.objects)
    glass = [o for o in objects if o.material.kind == "glass"]
    mirrors = [o for o in objects if o.material.kind == "mirror"]
    diffuse = [o for o in objects if o.material.kind == "diffuse"]
    lit = _lit_lights(scene)
    sun = environment_sun(scene.environment).light  # a light of the shadow and caustic maps too
    if sun is not None and np.any(sun.intensity > 0):
        lit.append(sun)
    view_params: dict = {"shadow_map_size": shadow_size}
    if glass:
        bounces, dropped = _bounces_that_pay(scene, bounces, BOUNCE_SHARE[quality])
    if glass and len(objects) > 1:  # glass with anything else, another glass object included
        view = "impostors"
        view_params.update(internal_bounces=bounces, impostor_size=impostor_size, merge_planes=True, convex_exits=True)
        why_glass = (f"other objects near it are seen through and in it as impostors (Hu and Qin 2.2; coplanar flat "
                     f"objects share one), {{exits}}, {bounces} internal bounce{'' if bounces == 1 else 's'}")
        why_mirror = "its reflections see the nearby objects as impostors (Hu and Qin 2.2)"
    elif glass:
        view = "depth-search"
        view_params.update(internal_bounces=bounces, convex_exits=True)
        why_glass = f"alone in the environment: {{exits}}, {bounces} internal bounce{'' if bounces == 1 else 's'}"
        why_mirror = ""
    elif failing := _per_vertex_fails(mirrors, scene):
        view = "impostors"
        view_params.update(impostor_size=impostor_size, merge_planes=True)
        why_mirror = (f"{failing}, where per-vertex's least-squares viewpoint fails: each pixel's reflected ray "
                      "searches the nearby objects as impostors (Hu and Qin 2.2)")
        why_glass = ""
    elif mirrors:
        view = "per-vertex"
        why_mirror = ("reflection exact at every vertex with a least-squares viewpoint (Kakimoto et al.); "
                      "exact for a flat mirror")
        why_glass = ""
    else:
        view = "env-map"
        why_glass = why_mirror = ""
    casters = glass + mirrors
    lit_casters = bool(casters and diffuse and lit)  # lights, something specular, and receivers
    paths = _caustic_paths(scene, lit) if lit_casters else None
    caustics = lit_casters and paths.landed
    unlanded = lit_casters and not caustics
    tabled = bool(caustics and not mirrors and _traced_table_pays(glass, paths.beyond_two))
    caustics_by = TABLE if tabled else CAUSTICS
    technique = f"{view}+{caustics_by}" if caustics else view
    params = dict(view_params)
    if caustics:
        sized = caustic_map_size(map_size, scene.camera.size if frame_size is None else frame_size)
        params[f"{caustics_by}.map_size"] = sized if caustics_by == CAUSTICS else map_size
    if tabled:  # the table's rays traced for the light's own directions: no table is looked up or cached
        params.update({f"{TABLE}.exit_rays": "traced", f"{TABLE}.photon_budget": table_photons})
    baked = _baked_receivers(scene)
    occluded = not baked and _occluded_ambient(scene)
    if baked:
        params["environment_bake"] = BAKE_SIZE
    elif occluded:
        params["environment_lobes"] = LOBES
    entries = []
    for obj in objects:
        kind = obj.material.kind
        if kind == "glass":
            entries.append(PlanEntry(obj.name, kind, view, why_glass.format(exits=_exits_of(obj))))
        elif kind == "mirror":
            entries.append(PlanEntry(obj.name, kind, view, why_mirror or "reflects the environment"))
        elif caustics:
            how = (f"the light transport of each glass object (Iwasaki et al.), its rays traced for the light's own "
                   f"directions (no table), {table_photons} photons: {paths.beyond_two:.0%} of the light crosses "
                   "other than two glass interfaces" if tabled else "caustic mapping (Shah et al.)")
            entries.append(PlanEntry(obj.name, kind, f"{view} + {caustics_by}",
                                     f"diffuse receiver: shadow maps, and caustics from {_lights(lit, sun)} through "
                                     f"{len(casters)} specular object(s) by {how}"
                                     + (OCCLUDED if occluded else "") + (_baked(obj, scene) if baked else "")))
        else:
            why = "diffuse: shadow maps and the environment's irradiance"
            if occluded:
                why += OCCLUDED
            if baked:
                why += _baked(obj, scene)
            if not lit:
                why += " (no light, so no caustics)"
            elif not casters:
                why += " (nothing specular casts caustics)"
            elif unlanded:
                why += (f" (no caustics: of {PLAN_PHOTONS} photons from {_lights(lit, sun)}, refracted "
                        "through the glass and reflected off the mirrors as caustic mapping follows them, "
                        f"{paths.share:.1%} of the flux reaches a diffuse surface, under {CAUSTIC_SHARE:.0%})")
            entries.append(PlanEntry(obj.name, kind, view, why))
    notes = []
    if glass and dropped:
        notes.append(f"{dropped} internal bounce(s) of the quality's {bounces + dropped} left out: each would carry "
                     f"less than {BOUNCE_SHARE[quality]:.1%} of the light in the glass pixels (exact paths at "
                     f"{BOUNCE_VIEW[0]}x{BOUNCE_VIEW[1]})")
    if not objects:
        notes.append("the scene has no objects: the environment alone")
    thin = thin_walled_glass(scene)
    if thin:
        notes.append(thin_walled_note(thin))
    return Plan(technique, params, quality, entries, notes)


def _lit_lights(scene) -> list:
    """The scene's lights that shine (some intensity above 0)."""
    return [light for light in scene.lights if np.any(np.asarray(light.intensity) > 0)]


def _sheds_light(environment) -> bool:
    """Whether the environment sheds any light (its SH irradiance's constant term above 0 in some channel)."""
    return bool(np.any(environment.irradiance_sh()[0] > 0))


OCCLUDED = (f"; the sky's light shadowed by the other objects: environment_lobes ({LOBES} by default) sky strata "
            "of equal power, each a directional shadow map, glass passing its transmittance, the blocked sky showing "
            "the occluders' bounce and the light from below a floor's (docs/environment-light.md: diffuse +1.1 to "
            "+5.1 dB against Mitsuba)")


def _occluded_ambient(scene) -> bool:
    """Whether the environment lobes' shadows pay: diffuse surfaces with another object to occlude their
    environment light, an environment that sheds some, and no lights of the scene's own (where the scene has
    lights, the sky's share of the diffuse light is too small to pay), and a floor (whose bounce the lobes bring)
    or objects that block more than LOBE_SHARE of the sky on the diffuse surfaces (lobe_occlusion: exact rays
    towards each lobe). The measurements behind the rule: docs/auto.md and docs/environment-light.md."""
    diffuse = [o for o in scene.objects if o.material.kind == "diffuse"]
    return (bool(diffuse) and len(scene.objects) > 1 and not scene.lights
            and _sheds_light(scene.environment)
            and (scene_floor(scene) is not None or lobe_occlusion(scene) > LOBE_SHARE))


def _baked(obj, scene) -> str:
    """The plan's reason for the light maps (environment_lights.bake_plan), on each diffuse object's entry."""
    receiver = bake_plan(scene).receivers[next(i for i, o in enumerate(scene.objects) if o is obj)]
    how = "baked with exact's rays: occluded, through glass (the sky's caustic), one bounce (docs/environment-light.md)"
    if not _sheds_light(scene.environment):  # nothing of the environment's: say what the bake carries
        return ("; the lights' light come back to it off the floor and through the glass (one bounce), from a light map "
                f"(environment_bake, {BAKE_SIZE} texels a side by default) baked with exact's rays; the environment "
                "is black and adds nothing (docs/auto.md)")
    if receiver.kind == "floor":
        return f"; the environment's light on it from a light map (environment_bake, {BAKE_SIZE} texels a side by default) {how}"
    if receiver.kind == "box":
        return f"; the environment's light on its faces from light maps ({FACE_SIZE} texels a side) {how}"
    if receiver.kind == "plane":
        return f"; the environment's light on it from the light map of its plane (both sides) {how}"
    capped = (f", {receiver.baked} of its {receiver.vertices} vertices baked (VERTEX_CAP {VERTEX_CAP}), the others "
              "interpolated from the nearest" if receiver.baked < receiver.vertices else "")
    return f"; the environment's light on it baked per vertex{capped}, {how}"


def _baked_receivers(scene) -> bool:
    """Whether the light maps pay (environment_lights.bake_plan: the floor, box faces, planes, curved receivers per
    vertex): a diffuse object and another object, under an environment that sheds some light, with a floor (which
    the others shadow or the sky's caustic lights) or, without one, objects that take more than LOBE_SHARE of the
    sky's light on the diffuse faces the camera sees (lobe_occlusion; below it the unoccluded SH is kept); in any
    environment, where a light shines through glass onto a floor (:func:`_bounced_through_glass`)."""
    return (len(scene.objects) > 1 and any(o.material.kind == "diffuse" for o in scene.objects)
            and _sheds_light(scene.environment)
            and (scene_floor(scene) is not None or lobe_occlusion(scene) > LOBE_SHARE)) or _bounced_through_glass(scene)


def _bounced_through_glass(scene) -> bool:
    """Whether a light of the scene shines through glass onto a floor (of PLAN_PHOTONS photons, CAUSTIC_SHARE at
    least of the flux lands: _caustic_paths): then the floor's own diffuse light comes back to it through the
    glass, which no raster pass carries and the light maps' one bounce does (raytrace/environment_bake.py),
    even in a black environment (docs/auto.md, "The floor's light back through the glass")."""
    lit = _lit_lights(scene)
    return (bool(lit) and scene_floor(scene) is not None and any(o.material.kind == "glass" for o in scene.objects)
            and _caustic_paths(scene, lit).landed)


# quality -> the least share of the glass pixels' light an internal bounce must carry to be followed (high: all)
BOUNCE_SHARE = {"draft": 0.0, "balanced": 3e-3, "high": 0.0}
BOUNCE_VIEW = (64, 48)  # the camera's pixels at which the exact paths measure the bounces' shares


def _bounces_that_pay(scene, bounces: int, least: float) -> tuple[int, int]:
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


# The lobes pay where objects block more than this share of the sky on diffuse surfaces (docs/auto.md, the lobes).
LOBE_SHARE = 1e-2
PLAN_PHOTONS = 4096  # photons that decide whether a light's caustic reaches a diffuse surface at all
# The least share of the flux the lights send towards the casters that must land on diffuse surfaces as caustics
# for a caustic map to pay (docs/auto.md, caustic mapping: below it the map changed no pixel).
CAUSTIC_SHARE = 1e-2


@dataclass(frozen=True)
class CausticPaths:
    """What PLAN_PHOTONS exact photons say of a scene's caustics (:func:`_caustic_paths`)."""

    landed: bool  # CAUSTIC_SHARE at least of the flux sent towards the casters reached a diffuse surface
    beyond_two: float  # the share of the landed flux that crossed other than two glass interfaces
    share: float = 0.0  # the landed flux over the flux sent towards the casters


def _caustic_paths(scene, lit: list) -> CausticPaths:
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


def _lights(lit: list, sun) -> str:
    """'N light(s)', naming the environment's sun among them (passes/shading/environment.py)."""
    text = f"{len(lit)} light(s)"
    return text + (", the environment's sun among them (a directional light)" if any(x is sun for x in lit) else "")


CONCAVE = 0.25  # a mirror is concave when this fraction of its surface bends towards the camera
# Per-vertex pays while its least-squares viewpoint sees the mirror's hits within this many degrees of the reflected
# rays on average (per_vertex.viewpoint_parallax; Kakimoto et al. 3.2); above it impostors is ahead (the presets'
# angles and scores: docs/auto.md). No hysteresis: the plan is a function of the scene's state and camera, so that
# batch workers rendering frames in any order plan alike (docs/determinism.md).
PARALLAX = 0.3
NESTED = 0.01  # a mirror whose vertices' rays meet another mirror this often keeps per-vertex (Kakimoto et al. 4.4)


def _per_vertex_fails(mirrors: list, scene) -> str:
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


TABLE_SHARE = 0.05  # the share of caustic flux beyond two interfaces from which the traced table pays (docs/auto.md)


def _traced_table_pays(glass: list, beyond_two: float) -> bool:
    """Whether ``transport-table`` with its rays traced for the light (``exit_rays="traced"``: no table to cache)
    gives the caustics of ``glass`` better than caustic mapping: every object a solid of one IOR (Iwasaki et
    al. 4 trace through closed objects; not a water sheet; dispersive glass, whose rays would be traced once per
    channel, keeps caustic mapping), one at least not convex, and more than TABLE_SHARE of the caustic flux on
    other than the two interfaces caustic mapping estimates (Shah et al. 3.1). In convex glass the light beyond
    two interfaces is reflected totally inside, which caustic mapping's exit_reflections follow. The scenes that
    set TABLE_SHARE: docs/auto.md, "Which glass takes the traced table"."""
    from ..passes.caustics.casters import nearly_closed

    return (all(nearly_closed(o.mesh) and o.material.abbe is None for o in glass)
            and not all(o.mesh.is_convex() for o in glass) and beyond_two > TABLE_SHARE)


class Auto(Technique):
    """``auto``: the plan's technique for each scene (:func:`plan`)."""

    name = "auto"
    summary = "The most accurate real-time combination for the scene: impostors, depth-search or per-vertex, with caustics"
    Params = AutoParams
    role = "planner"
    plan_used: Plan | None = None  # the plan of the last for_scene (the renderer keeps it as last_plan)

    def make_params(self, **values):
        """``quality``, ``budget_ms``, and any other parameter for the planned technique (checked once
        the plan is made)."""
        own = {name: values.pop(name) for name in ("quality", "budget_ms", "environment_lobes", "environment_bake")
               if name in values}
        params = super().make_params(**own)
        params.overrides = values  # not a field: what the plan's technique takes depends on the scene
        params.given = frozenset(own)  # auto's own parameters named by the caller: they win over the plan's rules
        return params

    def for_scene(self, scene, params, frame_ms=None, frame_size=None):
        """The planned technique and its parameters. With a budget, ``frame_ms(technique, params)``
        (the renderer's measured, cached frame time) picks the highest quality that fits;
        ``frame_size``: the supersampled pixels of the frame (the caustic map follows it)."""
        if not params.budget_ms:
            return self._planned(scene, params.quality, params, frame_size)
        if frame_ms is None:
            raise TechniqueError("auto's budget_ms needs frame times measured by a Renderer; render through one")
        costs = {}
        for quality in ("high", "balanced", "draft"):
            technique, values = self._planned(scene, quality, params, frame_size)
            costs[quality] = frame_ms(technique, values)
            if costs[quality] <= params.budget_ms:
                measured = ", ".join(f"{name} {ms:.1f} ms" for name, ms in costs.items())
                self.plan_used.notes.append(f"budget {params.budget_ms:g} ms: {quality}, the highest quality that "
                                            f"fits (measured here: {measured})")
                return technique, values
        # The cheapest as measured (a loaded moment may time draft above balanced): what the smallest budget is.
        cheapest = min(costs, key=costs.get)
        raise TechniqueError(f"budget {params.budget_ms:g} ms is below the cheapest plan's {costs[cheapest]:.1f} ms "
                             f"per frame here ({cheapest}); give a budget of {costs[cheapest] * 1.1:.0f} ms or more, "
                             "or a smaller size")

    def _planned(self, scene, quality: str, params, frame_size=None):
        chosen = self.plan_used = plan(scene, quality, frame_size)
        technique = get_technique(chosen.technique)
        overrides = getattr(params, "overrides", {})
        try:
            values = technique.make_params(**{**chosen.params, **overrides})
        except TechniqueError as exc:  # the list of parameters is the planned technique's: point to it
            reason = str(exc).split("; its parameters are:")[0]
            raise TechniqueError(f"auto planned '{chosen.technique}' for this scene: {reason}; "
                                 f"see 'caustica techniques {chosen.technique}'") from None
        # The environment's light (ShadowMaps reads the view's: environment_lights.bake_settings, lobe_settings).
        view_values = values[0] if isinstance(values, tuple) else values  # a composite's: (view, caustics)
        given = getattr(params, "given", ())
        # Lobes named without a light map: the lobes light the floor too (the rule set aside for both).
        bake = params.environment_bake if "environment_bake" in given or (
            "environment_lobes" not in given and "environment_bake" in chosen.params) else 0
        # The light maps replace the lobes (the lobes' change beside the floor's map did not pay: docs/auto.md); with
        # every receiver baked none is left to them.
        lobes = params.environment_lobes if "environment_lobes" in given or (
            not bake and _occluded_ambient(without_invisible_glass(scene))) else 0
        for name, value in (("environment_bake", bake), ("environment_lobes", lobes)):
            for half in values if isinstance(values, tuple) else (values,):
                setattr(half, name, value if half is view_values else 0)
            # The plan's parameters are what renders: the planned technique named with them gives auto's image.
            chosen.params.pop(name, None)
            if value:
                chosen.params[name] = value
            if name in given:
                chosen.notes.append(f"{name}={getattr(params, name)} as given (the plan's rule set aside)")
        return technique, values
