"""The rules of ``auto``'s plan: the most accurate real-time combination for the scene at hand, planned from
its contents.

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
photons). What the rules measure with exact rays (the bounces' shares, the caustics' paths, the sky's
occlusion, the mirrors' parallax) is in :mod:`caustica.planning.probes`.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

import numpy as np

from ..errors import TechniqueError
from ..lighting.bake import bake_plan
from ..lighting.environment import LOBES, environment_sun
from ..passes.shading.convex_exits import convex_shape
from ..raytrace.environment_bake import BAKE_SIZE, FACE_SIZE, VERTEX_CAP
from ..scene.gltf.origin import thin_walled_glass, thin_walled_note
from ..scene.gltf.read import GLASS_ROUGHNESS
from ..scene.materials import Principled
from ..scene.scene import invisible_objects, without_invisible_glass
from .probes import (BOUNCE_VIEW, CAUSTIC_SHARE, PLAN_PHOTONS, baked_receivers, bounces_that_pay, caustic_paths,
                     lit_lights, occluded_ambient, per_vertex_fails, sheds_light)

QUALITY = {  # quality -> (internal bounces, impostor texels, caustic-map texels, shadow-map texels, table photons)
    "draft": (0, 256, 256, 512, 1 << 16),
    "balanced": (2, 512, 512, 1024, 1 << 17),
    "high": (4, 1024, 1024, 2048, 1 << 18),
}
CAUSTICS = "caustic-mapping"
MIN_CAUSTIC_MAP = 256  # the smallest caustic map auto plans (caustic_map_size)
TABLE = "transport-table"  # the caustics where every caster is solid glass whose light crosses it more than twice


@dataclass
class PlanEntry:
    """What renders one object, and why."""

    object: str
    kind: str  # the object's material kind
    handled_by: str
    reason: str
    material: str = ""  # how its material is drawn (drawn_as)


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
            lines.append(f"  {entry.object} ({entry.material or entry.kind}): {entry.handled_by}: {entry.reason}")
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
        chosen = _plan_visible(scene, quality, frame_size)
    else:
        visible = without_invisible_glass(scene)
        chosen = _plan_visible(visible, quality, frame_size)
        chosen.params["drop_invisible_glass"] = True
        planned = {id(o): entry for o, entry in zip(visible.objects, chosen.objects)}
        chosen.objects = [planned.get(id(o)) or PlanEntry(o.name, o.material.kind, "left out", INVISIBLE)
                          for o in scene.objects]
    for entry, obj in zip(chosen.objects, scene.objects, strict=True):
        entry.material = drawn_as(obj.material)
    return chosen


def drawn_as(material) -> str:
    """How ``material`` is drawn, in a few words (docs/materials.md): the shorthands by their kind; a
    Principled by its drawing role, its GGX lobe and maps, and what of it is not drawn yet."""
    if not isinstance(material, Principled):
        return material.kind
    m = material
    if m.kind == "glass":
        undrawn = [f"roughness {m.roughness:g} not drawn"] if m.roughness > GLASS_ROUGHNESS else []
        if np.any(m.base_color < 1.0):
            undrawn.append("base colour tint not drawn")
        if m.transmission < 1.0:
            undrawn.append(f"transmission {m.transmission:g} drawn as 1")
        return f"glass, smooth: {'; '.join(undrawn)}" if undrawn else "glass"
    if m.kind == "mirror":
        return "mirror" if m.roughness == 0.0 else f"mirror, perfectly smooth: roughness {m.roughness:g} not drawn"
    if m.glossy:
        if m.metallic == 1.0:
            what = "glossy metal"
        elif m.metallic == 0.0:
            what = "glossy dielectric"
        else:
            what = f"glossy, metallic {m.metallic:g}"
        parts = [f"{what}, GGX roughness {m.roughness:g}"]
    else:
        parts = ["diffuse"]
    for name, texture in (("metallic-roughness map", m.metallic_roughness_texture),
                          ("normal map", m.normal_texture), ("occlusion map", m.occlusion_texture)):
        if texture is not None:
            parts.append(name)
    if np.any(m.emission > 0):
        parts.append("emissive")
    if m.transmission > 0:
        parts.append(f"transmission {m.transmission:g} not drawn")
    return ", ".join(parts)


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
    lit = lit_lights(scene)
    sun = environment_sun(scene.environment).light  # a light of the shadow and caustic maps too
    if sun is not None and np.any(sun.intensity > 0):
        lit.append(sun)
    view_params: dict = {"shadow_map_size": shadow_size}
    if glass:
        bounces, dropped = bounces_that_pay(scene, bounces, BOUNCE_SHARE[quality])
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
    elif failing := per_vertex_fails(mirrors, scene):
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
    paths = caustic_paths(scene, lit) if lit_casters else None
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
    baked = baked_receivers(scene)
    occluded = not baked and occluded_ambient(scene)
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


OCCLUDED = (f"; the sky's light shadowed by the other objects: environment_lobes ({LOBES} by default) sky strata "
            "of equal power, each a directional shadow map, glass passing its transmittance, the blocked sky showing "
            "the occluders' bounce and the light from below a floor's (docs/environment-light.md: diffuse +1.1 to "
            "+5.1 dB against Mitsuba)")


def _baked(obj, scene) -> str:
    """The plan's reason for the light maps (environment_lights.bake_plan), on each diffuse object's entry."""
    receiver = bake_plan(scene).receivers[next(i for i, o in enumerate(scene.objects) if o is obj)]
    how = "baked with exact's rays: occluded, through glass (the sky's caustic), one bounce (docs/environment-light.md)"
    if not sheds_light(scene.environment):  # nothing of the environment's: say what the bake carries
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


# quality -> the least share of the glass pixels' light an internal bounce must carry to be followed (high: all)
BOUNCE_SHARE = {"draft": 0.0, "balanced": 3e-3, "high": 0.0}


def _lights(lit: list, sun) -> str:
    """'N light(s)', naming the environment's sun among them (passes/shading/environment.py)."""
    text = f"{len(lit)} light(s)"
    return text + (", the environment's sun among them (a directional light)" if any(x is sun for x in lit) else "")


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
