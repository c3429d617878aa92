"""Glass standing on a receiver under every technique auto can pick: a bevelled glass box standing on a floor with a
mirror cap on it (a product shot's bottle). The bevel leaves the bottom a smaller flat face ringed by slanted ones,
and only that face lies on the floor (passes/shading/glass_contact.py). Each view technique, nearby option and
caustic technique composed with them renders it, and where the view through the glass reaches the face lying on the
floor it lands there (Wyman's nearby planes included) and sees the floor lit as exact lights it."""
from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest
from test_glass_contact import interior

from caustica.passes.shading.convex_exits import convex_shape
from caustica.passes.shading.glass_contact import contact_plane
from caustica.raytrace.embree_scene import ray_scene_for
from caustica.raytrace.paths import interface
from caustica.scene import Camera, Diffuse, Environment, Glass, Mirror, PointLight, Scene, SceneObject, Transform
from caustica.scene.io import export_scene, load_scene
from caustica.scene.mesh import Mesh
from caustica.scene.shapes import cylinder, plane
from caustica.techniques.exact import Exact, ExactParams

HALF, HEIGHT, BEVEL = 0.4, 0.5, 0.06  # the box: [-HALF, HALF] x [0, HEIGHT] x [-HALF, HALF], its edges cut by BEVEL
ALBEDO, IOR = 0.5, 1.5
LIGHT = np.array([0.5, 3.0, 0.8])
BLACK = Environment(np.zeros((32, 64, 3), np.float32))


def bevelled_box(size, bevel: float) -> Mesh:
    """A box of edge lengths ``size`` about the origin with every edge cut at 45 degrees, ``bevel`` in from each
    face: 6 faces, 12 edge strips and 8 corner triangles, each flat (its own vertices and normal)."""
    half = np.asarray(size, np.float64) / 2
    corners = list(itertools.product((-1.0, 1.0), repeat=3))

    def vertex(corner, axis):  # the corner's vertex on the face across ``axis``
        v = np.array(corner) * (half - bevel)
        v[axis] = corner[axis] * half[axis]
        return v

    polygons = [[vertex(c, k) for c in corners if c[k] == sign] for k in range(3) for sign in (-1.0, 1.0)]
    for i, j in itertools.combinations(range(3), 2):
        for si, sj in itertools.product((-1.0, 1.0), repeat=2):
            ends = [c for c in corners if c[i] == si and c[j] == sj]
            polygons.append([vertex(c, i) for c in ends] + [vertex(c, j) for c in ends])
    polygons += [[vertex(c, k) for k in range(3)] for c in corners]
    vertices, normals, faces = [], [], []
    for polygon in map(np.array, polygons):  # convex polygons: fanned around their centre's angle, outward
        centre = polygon.mean(axis=0)
        normal = np.cross(polygon[1] - polygon[0], polygon[2] - polygon[0])
        normal *= np.sign(normal @ centre) / np.linalg.norm(normal)
        u = polygon[0] - centre
        w = np.cross(normal, u)
        ordered = polygon[np.argsort(np.arctan2((polygon - centre) @ w, (polygon - centre) @ u))]
        base = len(vertices)
        vertices += list(ordered)
        normals += [normal] * len(ordered)
        faces += [[base, base + m, base + m + 1] for m in range(1, len(ordered) - 1)]
    return Mesh(np.array(vertices), np.array(normals), np.array(faces), name="bevelled-box")


def standing_scene(material=None, environment=BLACK, lights=None, camera=None) -> Scene:
    """The bevelled box of ``material`` (glass of IOR) standing on a floor, a short gold mirror cylinder on its top,
    under ``lights`` (a point light above and aside)."""
    material = material or Glass(ior=IOR)
    lights = [PointLight(position=LIGHT, intensity=[20.0] * 3)] if lights is None else lights
    camera = camera or Camera(position=[0.0, 2.2, 1.3], look_at=[0.0, 0.2, 0.0], fov_y=36.0, size=(64, 48))
    floor = SceneObject("floor", plane((6.0, 6.0)), Diffuse([ALBEDO] * 3))
    glass = SceneObject("bottle", bevelled_box((2 * HALF, HEIGHT, 2 * HALF), BEVEL), material,
                        Transform(position=[0.0, HEIGHT / 2, 0.0]))
    cap = SceneObject("cap", cylinder(0.12, 0.1, 32), Mirror([0.9, 0.75, 0.4]), Transform(position=[0.0, HEIGHT + 0.05, 0.0]))
    return Scene(camera=camera, objects=[floor, glass, cap], lights=list(lights), environment=environment)


def test_the_box_stands_on_the_floor_by_its_bottom_face_alone():
    """The floor is the plane the box stands on, and the box is a solid of its 26 planes (convex_exits computes its
    exits; convex_exits=False searches them)."""
    scene = standing_scene()
    assert np.allclose(contact_plane(scene, scene.objects[1]), [0.0, 1.0, 0.0, 0.0])
    assert len(convex_shape(scene.objects[1]).planes) == 26


def through_top_onto_the_bottom_face(scene: Scene, ior: float) -> np.ndarray:
    """(H, W) the pixels whose view ray enters the box's top face and, refracted there, reaches the floor's plane
    inside the bottom face (0.02 in from its edges): the view that lands on the floor under the box."""
    origins, dirs = (a.reshape(-1, 3).astype(np.float64) for a in scene.camera.primary_rays(1))
    hits = ray_scene_for(scene).intersect(origins, dirs)
    top = (hits.object_index == 1) & (hits.geometric_normal[:, 1] > 0.99)
    t = interface(dirs, hits.normal, hits.geometric_normal, np.full(len(dirs), ior)).refracted
    with np.errstate(divide="ignore", invalid="ignore"):
        landing = hits.position - (hits.position[:, 1] / t[:, 1])[:, None] * t
    inside = np.all(np.abs(landing[:, [0, 2]]) < HALF - BEVEL - 0.02, axis=1)
    width, height = scene.camera.size
    return interior((top & inside).reshape(height, width))


# The techniques auto picks for this scene (impostors, with caustic mapping or the traced transport table) and the
# ones a user can pick instead: depth-search with each nearby option, each caustic technique composed with a view,
# exits exact (convex_exits) and searched, and per-vertex (the cap).
SEARCHED = {"internal_bounces": 2}
EXACT_EXITS = {"internal_bounces": 2, "convex_exits": True}


def composed(view: str, caustics: str | None, view_params: dict, **params) -> tuple[str, dict]:
    """(technique name, parameters) of ``view`` (with ``caustics`` composed, when given), the view's own
    parameters prefixed in a composite."""
    if caustics is None:
        return view, {**view_params, **params}
    return f"{view}+{caustics}", {**{f"{view}.{k}": v for k, v in view_params.items()}, **params}


EVERY_TECHNIQUE = [
    ("auto", {}), ("auto", {"quality": "draft"}), ("per-vertex", {}), ("per-vertex+caustic-mapping", {}),
    composed("impostors", None, EXACT_EXITS), composed("impostors", None, SEARCHED),
    composed("impostors", "caustic-mapping", SEARCHED), composed("impostors", "photon-splats", EXACT_EXITS),
    composed("impostors", "transport-table", SEARCHED, **{"transport-table.exit_rays": "traced"}),
    composed("impostors", "impostor-caustics", {"convex_exits": True}),
    *[composed("depth-search", None, {**SEARCHED, "nearby": nearby})
      for nearby in ("none", "planes", "search-linear", "search-binary", "search-secant")],
    composed("depth-search", None, {**EXACT_EXITS, "nearby": "planes"}),
    composed("depth-search", "caustic-mapping", {**EXACT_EXITS, "nearby": "search-secant"}),
    composed("depth-search", "photon-splats", {**SEARCHED, "nearby": "planes"}),
]


@pytest.mark.parametrize("technique, params", EVERY_TECHNIQUE, ids=[f"{t}-{i}" for i, (t, _) in enumerate(EVERY_TECHNIQUE)])
def test_standing_glass_with_a_cap_renders(renderer, technique, params):
    """The glass standing on the floor with its cap builds and renders (every shader variant compiles): finite, and
    the floor lit around it (the frame's mean above 0.05; about 0.2 with every technique, black outside the light's
    reach)."""
    image = renderer.render(standing_scene(), technique, **params)
    assert np.isfinite(image).all()
    assert image.mean() > 0.05
    if technique == "auto":
        assert renderer.last_plan.technique in ("impostors+caustic-mapping", "impostors+transport-table")


def test_standing_glass_through_gltf_renders_under_auto(renderer, tmp_path):
    """The same scene written as glTF by caustica and read back (the bottle's glass, the cap's metal; the black sky
    given again, glTF has none) renders under auto as it did: finite, the same plan, within 1 % of the frame's mean."""
    scene = standing_scene()
    export_scene(scene, tmp_path / "bottle.gltf")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loaded = load_scene(tmp_path / "bottle.gltf")
    loaded.environment = scene.environment  # glTF holds none
    assert [o.material.kind for o in loaded.objects] == ["diffuse", "glass", "mirror"]
    before = renderer.render(scene, "auto")
    planned = renderer.last_plan.technique
    after = renderer.render(loaded, "auto")
    assert renderer.last_plan.technique == planned
    assert np.isfinite(after).all()
    assert abs(after.mean() / before.mean() - 1.0) < 0.01


@pytest.fixture(scope="module")
def exact_standing():
    """exact's image of the standing scene (400,000 caustic photons), (H, W, 3)."""
    scene = standing_scene()
    image = Exact().render(scene, scene.camera, ExactParams(caustic_photons=400_000), 1)
    assert np.isfinite(image).all()
    return image


# Every technique whose view through the glass meets the floor and whose floor there carries the light through the
# glass (a caustic): impostors and depth-search with Wyman's nearby planes, each with the three caustic techniques
# that land light through a face lying on the receiver, exits exact and searched.
LIT_UNDER = [
    ("auto", {}),
    *[composed(view, caustics, {**exits, **nearby}, **extra)
      for view, nearby in (("impostors", {}), ("depth-search", {"nearby": "planes"}))
      for caustics, extra in (("caustic-mapping", {}), ("photon-splats", {}),
                              ("transport-table", {"transport-table.exit_rays": "traced"}))
      for exits in (SEARCHED, EXACT_EXITS)],
]


@pytest.mark.parametrize("technique, params", LIT_UNDER, ids=[f"{t}-{i}" for i, (t, _) in enumerate(LIT_UNDER)])
def test_floor_under_standing_glass_is_lit_as_exact_lights_it(renderer, exact_standing, technique, params):
    """Seen through the top face, the floor under the box (the light reaching it through the glass, the cap's
    shadow in it) has exact's mean radiance within 25 %: the caustic techniques' estimates of the light through
    the glass differ from exact's photons by up to 13 % on this region (photon splats 0.88 of it, caustic mapping
    0.97, the traced table 1.06-1.13), exact's own photon noise there is under 1 %; a view that misses its
    landing sees the black sky (0: depth-search's nearby planes took no hit at the plane the lookup starts on)."""
    scene = standing_scene()
    region = through_top_onto_the_bottom_face(scene, IOR)
    expected = exact_standing[region].mean()
    assert region.sum() > 100 and expected > 0.2
    image = renderer.render(scene, technique, **params)
    assert abs(image[region].mean() / expected - 1.0) < 0.25


NEARBY_VIEWS = [composed("impostors", None, exits) for exits in (SEARCHED, EXACT_EXITS)] + [
    composed("depth-search", None, {**exits, "nearby": nearby})
    for nearby in ("planes", "search-linear", "search-binary", "search-secant") for exits in (SEARCHED, EXACT_EXITS)]


@pytest.mark.parametrize("technique, params", NEARBY_VIEWS, ids=[f"{t}-{i}" for i, (t, _) in enumerate(NEARBY_VIEWS)])
def test_view_through_clear_standing_glass_lands_on_the_floor(renderer, technique, params):
    """An IOR-1 bevelled box (with its cap) standing on the floor under a constant white sky, seen from straight
    above: the view through the top face leaves through the bottom face lying on the floor and lands on it, so each
    such pixel is the floor's radiance, its albedo (0.5) within 0.02, not the sky's 1 (depth-search's nearby planes:
    0.95 on average before)."""
    camera = Camera(position=[0.0, 6.0, 0.01], look_at=[0.0, 0.0, 0.0], fov_y=16.0, size=(48, 48))
    white = Environment(np.ones((64, 128, 3), np.float32))
    scene = standing_scene(Glass(ior=1.0), white, lights=[], camera=camera)
    region = through_top_onto_the_bottom_face(scene, 1.0)
    assert region.sum() > 150
    image = renderer.render(scene, technique, **params)
    assert np.abs(image[region] - ALBEDO).max() < 0.02
