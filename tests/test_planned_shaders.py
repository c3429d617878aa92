"""Every shading program ``auto`` can plan compiles, and glass that is no solid of planes, balls and cylinders
renders standing on a floor (issue 43: depth_search.frag called the contact test that only CONVEX_EXITS included).

The compile test takes the planned techniques from :func:`caustica.planning.rules.plan` on scenes of each kind it
tells apart, at every quality, and their ShadeSurfaces passes' own defines from their ``build_passes``. The defines a
frame adds (material variants, optional inputs, deferred stages, the frame's glass) are free: a small evaluator of the
preprocessor's ``#if`` lines walks the shader's source and branches on a free define only where an active condition
reads it, so each distinct preprocessed program is compiled once, without a product of every value.
"""
from __future__ import annotations

import itertools
import re
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

from caustica.gpu.shaders import ShaderError
from caustica.lighting.samples import MAX_LIGHTS
from caustica.passes.shading import deferred
from caustica.passes.shading.convex_exits import CONVEX_EXITS_MODES, convex_shape
from caustica.passes.shading.glass_contact import contact_plane
from caustica.passes.shading.surfaces import ShadeSurfaces
from caustica.planning.rules import QUALITY, plan
from caustica.render.bindings import MAX_CAUSTIC_TILES
from caustica.scene import Camera, Diffuse, Environment, Glass, Mirror, PointLight, Scene, SceneObject, Transform
from caustica.scene.codes import MATERIAL_CODES
from caustica.scene.mesh import Mesh, vertex_normals
from caustica.scene.shapes import plane, sphere, torus_knot
from caustica.techniques import get_technique

SKY = Environment(np.full((16, 32, 3), 0.5, np.float32))
ABSENT = None  # a free define's value: not defined at all
# The defines ShadeSurfaces._draw_objects and passes/shading/deferred.py add per frame, with every value they take.
FREE_DEFINES = {
    **{define: (0, 1) for define in ShadeSurfaces.optional.values() if define},  # optional inputs: written or not
    "SURFACE_KIND": tuple(sorted(set(MATERIAL_CODES.values()))),
    "DISPERSION": (0, 1),
    "ALBEDO_TEXTURE": (ABSENT, 1),
    "ENVIRONMENT_BAKE_VERTICES": (ABSENT, 1),
    "ENVIRONMENT_GLASS": (0, 1), "ENVIRONMENT_BOUNCE": (0, 1),  # EnvironmentShadows.defines
    "DEFERRED_SHADING": (ABSENT, deferred.DEFER_SHADE_NOW, deferred.DEFER_GBUFFER, deferred.DEFER_RESOLVE),
    "DEFER_STAGE": (ABSENT, 1, 2),
    "CAPTURE_FRONT_SURFACE": (ABSENT, 1),
}
# The values of the frame_defines functions' defines (contact_defines, convex_defines, impostor_defines,
# plane_defines); a define they add that is not here fails test_free_defines_cover_what_frames_add.
FRAME_DEFINES = {"GLASS_CONTACT": (0, 1), "CONVEX_EXITS": CONVEX_EXITS_MODES, "IMPOSTORS_CURVED": (0, 1),
                 "PLANE_TEXTURES": (ABSENT, 1)}
FIXED_FRAME_DEFINES = ("MAX_CONVEX_PLANES", "MAX_CONVEX_QUADRICS", "MAX_IMPOSTORS")  # sizes, not code paths


def rounded_box() -> Mesh:
    """A glass block with rounded edges (the hull of balls at a box's corners): hundreds of face planes, so no
    solid of convex_exits (its exits are searched), with its flat bottom on y = 0."""
    ball = trimesh.creation.icosphere(1, 0.08).vertices
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * [0.42, 0.22, 0.42]
    hull = trimesh.convex.convex_hull((corners[:, None] + ball[None]).reshape(-1, 3))
    hull.apply_translation([0.0, 0.3, 0.0])
    vertices, faces = np.asarray(hull.vertices, np.float32), np.asarray(hull.faces, np.int32)
    return Mesh(vertices, vertex_normals(vertices, faces), faces)


def floor() -> SceneObject:
    return SceneObject("floor", plane((6.0, 6.0)), Diffuse([0.8, 0.8, 0.8]))


def scene_of(*objects, lights=(), size=(64, 48)) -> Scene:
    camera = Camera(position=[0.0, 1.6, 2.4], look_at=[0.0, 0.25, 0.0], fov_y=40.0, size=size)
    return Scene(camera=camera, objects=list(objects), lights=list(lights), environment=SKY)


def bevelled_box_on_floor(size=(48, 36)) -> Scene:
    block = SceneObject("block", rounded_box(), Glass(ior=1.5))
    return scene_of(floor(), block, lights=[PointLight(position=[0.6, 3.0, 0.4], intensity=[20.0] * 3)], size=size)


def plan_scenes() -> dict:
    """A scene for each kind of plan: glass standing on a floor, a ball alone, a knot over a floor (the traced
    transport table), a concave and a flat mirror over a floor, a floor alone."""
    ball = SceneObject("ball", sphere(0.4, 3), Glass(ior=1.5), Transform(position=[0.0, 0.5, 0.0]))
    knot = SceneObject("knot", torus_knot(2, 3, 0.35, 0.1, 96, 12), Glass(ior=1.5), Transform(position=[0.0, 0.5, 0.0]))
    light = PointLight(position=[0.3, 3.0, 0.2], intensity=[20.0] * 3)
    bowl = sphere(0.5, 2)
    bowl.faces = bowl.faces[bowl.vertices[bowl.faces].mean(axis=1)[:, 2] < 0]  # the far half: concave to the camera
    dish = SceneObject("dish", bowl, Mirror(), Transform(position=[0.0, 0.6, -0.4]))
    flat = SceneObject("mirror", plane((0.8, 0.6)), Mirror(), Transform(position=[0.0, 0.6, -0.6], rotation=[90, 0, 0]))
    return {"bevel": bevelled_box_on_floor(), "ball": scene_of(ball), "knot": scene_of(floor(), knot, lights=[light]),
            "dish": scene_of(floor(), dish), "flat-mirror": scene_of(floor(), flat), "floor": scene_of(floor())}


# A small evaluator of the preprocessor's conditions -------------------------------------------------------

_DIRECTIVE = re.compile(r"^\s*#\s*(\w+)\s*(.*?)\s*(?://.*)?$")
_TOKEN = re.compile(r"defined\s*\(\s*(\w+)\s*\)|defined\s+(\w+)|\d+[uU]?|\w+|&&|\|\||==|!=|<=|>=|\S")
_PYTHON = {"&&": " and ", "||": " or ", "!": " not ", "/": "//"}


def read_defines(source: str, free: dict, values: dict) -> tuple[set[str], tuple]:
    """The free defines that ``source``'s active preprocessor conditions read, with the free defines set as in
    ``values`` (ABSENT: not defined) and the others as their first value; and the branches taken (the program's
    shape: two settings with the same compile the same code but for the defines' values)."""
    macros = {name: str(value) for name, value in {**{k: v[0] for k, v in free.items()}, **values}.items()
              if value is not ABSENT}
    read = set()

    def defined(name: str) -> bool:
        if name in free:
            read.add(name)
        return name in macros

    def evaluate(text: str, depth: int = 0) -> int:
        parts = []
        for match in _TOKEN.finditer(text):
            token = match.group(0)
            if token.startswith("defined") and (match.group(1) or match.group(2)):
                parts.append(str(int(defined(match.group(1) or match.group(2)))))
            elif token[0].isdigit():
                parts.append(token.rstrip("uU"))
            elif token[0].isalpha() or token[0] == "_":
                parts.append(f"({evaluate(macros[token], depth + 1)})" if defined(token) and depth < 16 else "0")
            else:
                parts.append(_PYTHON.get(token, token))
        return int(eval("".join(parts) or "0", {}))  # integers and operators only

    active, taken = [True], [True]  # per open #if: its current branch is on (and every outer); some branch was
    trace = []
    for line in source.splitlines():
        match = _DIRECTIVE.match(line)
        if not match:
            continue
        directive, rest = match.groups()
        trace.append(active[-1])
        if directive in ("if", "ifdef", "ifndef"):
            on = active[-1] and bool(evaluate(rest) if directive == "if" else defined(rest) == (directive == "ifdef"))
            active.append(on)
            taken.append(on or not active[-2])
        elif directive in ("elif", "else"):
            on = not taken[-1] and active[-2] and (directive == "else" or bool(evaluate(rest)))
            active[-1], taken[-1] = on, taken[-1] or on
        elif directive == "endif":
            active.pop()
            taken.pop()
        elif directive == "define" and active[-1]:
            name, _, body = rest.partition(" ")
            macros[name.split("(")[0]] = body.strip() or "1"
        elif directive == "undef" and active[-1]:
            macros.pop(rest, None)
    return read, tuple(trace)


def covering(choices: dict, strength: int, allowed) -> list[dict]:
    """Assignments of ``choices`` (name -> values) that ``allowed(partial assignment)`` accepts, holding every
    allowed combination of values of any ``strength`` of the names at least once (greedy: each row takes, name
    by name, the allowed value completing most missing combinations)."""
    names = sorted(choices)
    groups = list(itertools.combinations(names, min(strength, len(names))))
    missing = {(group, combo) for group in groups for combo in itertools.product(*(choices[n] for n in group))
               if allowed(dict(zip(group, combo)))}
    groups_of = {name: [g for g in groups if name in g] for name in names}

    def gain(row: dict, name: str) -> int:  # the missing combinations that setting ``name`` completes
        return sum((g, tuple(row[n] for n in g)) in missing for g in groups_of[name] if all(n in row for n in g))

    def completed(row: dict, rest: list) -> dict | None:  # depth first, the most gaining values first
        if not rest:
            return row
        tries = [{**row, rest[0]: value} for value in choices[rest[0]]]
        for trial in sorted((t for t in tries if allowed(t)), key=lambda t: gain(t, rest[0]), reverse=True):
            if (found := completed(trial, rest[1:])) is not None:
                return found
        return None

    rows = []
    while missing:
        seed_group, seed = min(missing, key=repr)
        row = completed(dict(zip(seed_group, seed)), [n for n in names if n not in seed_group])
        if row is None:  # no whole assignment holds this combination
            missing.discard((seed_group, seed))
            continue
        missing -= {(g, tuple(row[n] for n in g)) for g in groups}
        rows.append(row)
    return rows


def host_allows(deferred_kinds, staged, captures):
    """Whether ShadeSurfaces (``deferred_kinds``, ``staged``, ``captures``: its options) sets the free defines of a
    partial assignment together: DISPERSION on glass, a texture and baked vertices on diffuse surfaces, deferred
    modes on the kinds it defers (untextured), stages on its staged kinds, the front-surface capture in the glass
    G-buffer draw, the environment shadows' atlases with them, caustic maps or tiles."""
    deferrable = {MATERIAL_CODES[kind] for kind in deferred_kinds}
    two_staged = {MATERIAL_CODES[kind] for kind in staged}
    glass, diffuse = MATERIAL_CODES["glass"], MATERIAL_CODES["diffuse"]

    def allowed(row: dict) -> bool:
        get = row.get
        kind, mode = get("SURFACE_KIND"), get("DEFERRED_SHADING", "?")
        rules = [
            not (get("DISPERSION") == 1 and kind not in (None, glass)),
            not (1 in (get("ALBEDO_TEXTURE"), get("ENVIRONMENT_BAKE_VERTICES")) and kind not in (None, diffuse)),
            not (mode in (deferred.DEFER_GBUFFER, deferred.DEFER_RESOLVE) and (
                kind is not None and kind not in deferrable or get("ALBEDO_TEXTURE") == 1)),
            not (mode == deferred.DEFER_SHADE_NOW and not deferrable),
            not (get("DEFER_STAGE") is not None and (mode not in ("?", deferred.DEFER_RESOLVE)
                                                     or kind is not None and kind not in two_staged)),
            not (get("CAPTURE_FRONT_SURFACE") == 1 and (not captures or mode not in ("?", deferred.DEFER_GBUFFER)
                                                        or kind not in (None, glass))),
            not (1 in (get("ENVIRONMENT_GLASS"), get("ENVIRONMENT_BOUNCE")) and get("ENVIRONMENT_SHADOWS") == 0),
            not (get("CAUSTICS") == 1 and get("CAUSTIC_TILES") == 1),
        ]
        return all(rules)

    return allowed


def variants(source: str, free: dict, allowed, strength: int = 2) -> list[dict]:
    """Settings of the free defines ``source`` reads, as ``allowed`` accepts them, that hold every combination of
    ``strength`` of their values (the defect class: a define's code used where another's condition left it out)."""
    read = read_defines(source, free, {})[0]
    while True:  # a value can switch on conditions reading more defines
        rows = covering({name: free[name] for name in read}, strength, allowed)
        more = set().union(*(read_defines(source, free, row)[0] for row in rows)) - read
        if not more:
            return rows
        read |= more


def planned_shading() -> dict:
    """(vertex, fragment, the pass's own defines, (its deferred and staged kinds, whether it captures the front
    surface)) -> the plans that run it, for each ShadeSurfaces pass of each
    technique auto plans on plan_scenes at every quality."""
    runs = {}
    for label, scene in plan_scenes().items():
        for quality in QUALITY:
            chosen = plan(scene, quality)
            technique = get_technique(chosen.technique)
            for shade in technique.build_passes(technique.make_params(**chosen.params)):
                if isinstance(shade, ShadeSurfaces):
                    own = {**shade.defines, "MAX_LIGHTS": MAX_LIGHTS, "MAX_CAUSTIC_TILES": MAX_CAUSTIC_TILES}
                    frame = SimpleNamespace(scene=scene, channels={})
                    added = shade.frame_defines(frame) if shade.frame_defines else {}
                    fixed = {k: v for k, v in added.items() if k in FIXED_FRAME_DEFINES}
                    own.update({k: ABSENT for k in FRAME_DEFINES if k not in added})  # not set: the shader's default
                    host = (shade.deferred, shade.staged, shade.captures_front_surface)
                    key = (shade.vertex, shade.fragment, tuple(sorted({**own, **fixed}.items())), host)
                    runs.setdefault(key, []).append(f"{chosen.technique} ({label}, {quality})")
    return runs


@pytest.fixture(scope="module")
def shading_runs():
    return planned_shading()


def test_the_plans_cover_every_view_auto_has(shading_runs):
    """The scenes reach each view technique of auto's plan, the glass views with both kinds of exits."""
    planned = " ".join(where for plans in shading_runs.values() for where in plans)
    for view in ("impostors+caustic-mapping", "depth-search", "impostors+transport-table", "per-vertex", "env-map"):
        assert view in planned, view
    scenes = plan_scenes()
    assert convex_shape(scenes["bevel"].objects[1]) is None and convex_shape(scenes["ball"].objects[0]) is not None
    assert contact_plane(scenes["bevel"], scenes["bevel"].objects[1]) is not None


def test_free_defines_cover_what_frames_add(shading_runs):
    """Every define a planned pass's frame_defines adds is a free define (its values enumerated) or a size."""
    free = {**FREE_DEFINES, **FRAME_DEFINES}
    for scene in plan_scenes().values():
        chosen = plan(scene, "draft")
        technique = get_technique(chosen.technique)
        for shade in technique.build_passes(technique.make_params(**chosen.params)):
            if isinstance(shade, ShadeSurfaces) and shade.frame_defines:
                added = shade.frame_defines(SimpleNamespace(scene=scene, channels={}))
                assert set(added) <= set(free) | set(FIXED_FRAME_DEFINES), sorted(added)


def test_every_planned_shading_program_compiles(renderer, shading_runs):
    """Each ShadeSurfaces program of every plan builds (a ShaderError names the file and line) under settings of
    the defines a frame adds that hold every pair of their values (variants)."""
    library = renderer.device.shaders
    free = {**FREE_DEFINES, **FRAME_DEFINES}
    resolve = "passes/shading/deferred_resolve.vert"
    shapes = set()
    for (vertex, fragment, given, host), plans in shading_runs.items():
        own = {k: v for k, v in given if v is not ABSENT}
        text = "\n".join(library.source(name, own)[0] for name in (vertex, fragment, resolve))
        run_free = {k: v for k, v in free.items() if k not in dict(given)}
        for values in variants(text, run_free, host_allows(*host)):
            chosen = {k: v for k, v in values.items() if v is not ABSENT}
            stage = resolve if chosen.get("DEFERRED_SHADING") == deferred.DEFER_RESOLVE else vertex
            shape = (stage, fragment, read_defines(text, run_free, values)[1])
            if shape in shapes:  # the same code as a program built already, the defines' values aside
                continue
            shapes.add(shape)
            try:
                library.program(stage, fragment, {**own, **chosen})
            except ShaderError as exc:  # name the plan and the defines that failed
                pytest.fail(f"{fragment} as {plans[0]} plans it, with {chosen}: {exc}")


def test_bevelled_box_standing_on_a_floor_renders_under_auto(renderer):
    """The rounded glass block on the floor under a point light renders with auto (impostors+caustic-mapping,
    exits searched, GLASS_CONTACT on: the shader compiled before the fix only with CONVEX_EXITS): finite, and
    the floor seen through the block's top within 50 % of exact's on average."""
    scene = bevelled_box_on_floor()
    image = renderer.render(scene, technique="auto")
    assert renderer.last_plan.technique == "impostors+caustic-mapping"
    assert np.isfinite(image).all()
    exact = renderer.render(scene, technique="exact")
    block = np.s_[17:25, 18:30]  # pixels seeing the floor through the block's top
    assert image[block].mean() > 0.05 and np.abs(image[block] - exact[block]).mean() < 0.5 * exact[block].mean()
