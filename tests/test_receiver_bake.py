"""The environment's light baked on every diffuse receiver (passes/environment_lights.bake_plan, scene_bake):
planes (a wall, a chart's squares) by their rectangle, curved meshes per vertex (capped), known answers under a
constant sky by view factors, and auto's plan and image where the scene has no floor (issues 23 and 19)."""
from __future__ import annotations

import numpy as np

from caustica.lighting.bake import bake_plan, scene_bake
from caustica.raytrace.environment_bake import VERTEX_CAP, bake_rectangles, bake_vertices, plane_of, plane_rectangle
from caustica.scene import Camera, Diffuse, Environment, Glass, Scene, SceneObject, Transform
from caustica.scene.shapes import box, plane, sphere

WHITE = Environment(np.ones((128, 256, 3), np.float32))
SIZE = (96, 72)
RAY = np.pi / 256  # what one of a texel's 256 cosine rays carries under the white sky


def ball(radius: float = 1.0, subdivisions: int = 3, position=(0.0, 0.0, 0.0), material=None, name="ball"):
    return SceneObject(name, sphere(radius, subdivisions), material or Diffuse([0.6] * 3), Transform(position=list(position)))


def wall(x: float, height: float = 3.0, length: float = 4.0, albedo: float = 0.0, name="wall") -> SceneObject:
    """A single quad in the plane x = ``x`` facing +x, centred on y = z = 0 (flat: no box)."""
    return SceneObject(name, plane((height, length)), Diffuse([albedo] * 3),
                       Transform(position=[x, 0.0, 0.0], rotation=[0.0, 0.0, -90.0]))


def scene_of(objects, camera=None) -> Scene:
    camera = camera or Camera(position=[3.0, 1.0, 3.0], look_at=[0.0, 0.0, 0.0], fov_y=50.0, size=SIZE)
    return Scene(camera=camera, objects=list(objects), environment=WHITE)


def rectangle_faces(obj) -> list[tuple]:
    """An object's flat faces as (origin, u, v, outward normal): a box's six, a quad's one."""
    from caustica.raytrace.environment_bake import box_faces

    faces = box_faces(obj)
    return faces if faces is not None else [plane_rectangle([obj], *plane_of(obj))]


def view_factor(points: np.ndarray, normals: np.ndarray, faces: list[tuple], steps: int = 120) -> np.ndarray:
    """Per point (n, 3) facing ``normals``, the view factor to a convex occluder's ``faces``: the sum over the faces
    whose outer side the point is on (for a convex body they do not overlap as seen from it) of the integral of
    max(0, cos_p) cos_f / (pi r^2) over the face, by the midpoint rule on a ``steps`` x ``steps`` grid."""
    total = np.zeros(len(points))
    s = (np.arange(steps) + 0.5) / steps
    for origin, u, v, normal in faces:
        q = (origin + s[:, None, None] * u + s[None, :, None] * v).reshape(-1, 3)
        cell = np.linalg.norm(np.cross(u, v)) / steps**2
        for start in range(0, len(points), 64):
            p, n = points[start:start + 64], normals[start:start + 64]
            d = q[None] - p[:, None]
            r2 = np.einsum("pqk,pqk->pq", d, d)
            cos_p = np.maximum(np.einsum("pqk,pk->pq", d, n), 0.0) / np.sqrt(r2)
            cos_f = np.maximum(-(d @ normal), 0.0) / np.sqrt(r2)
            outside = (p - origin) @ normal > 0.0
            total[start:start + 64] += np.where(outside, (cos_p * cos_f / (np.pi * r2)).sum(axis=1) * cell, 0.0)
    return total


def test_flat_objects_are_planes_and_coplanar_ones_share_a_rectangle():
    """A quad, a chart's squares (one object per colour, all in one plane) are flat; a sphere is not; the chart's
    groups share one rectangle that holds every square, its sides along the world axes."""
    from caustica.scene.presets_per_vertex import test_chart

    chart = test_chart(center=(0.0, 0.0, -0.5), size=1.0, cells=4)
    scene = scene_of([*chart, ball(0.2, 2, (0.0, 0.0, 0.5)), wall(-1.0)])
    plan = bake_plan(scene)
    kinds = [r.kind for r in plan.receivers]
    assert kinds == ["plane"] * len(chart) + ["vertices", "plane"]
    assert len(plan.planes) == 2 and sorted(plan.planes[0]) == list(range(len(chart)))
    origin, u, v, normal = plane_rectangle(chart, *plane_of(chart[0]))
    assert np.allclose(np.abs(normal), [0, 0, 1])
    # Squares 0.25 x 1.001 a side centred 0.375 and 0.125 either side of the centre: 0.75 + 0.25025 across.
    assert np.allclose([np.linalg.norm(u), np.linalg.norm(v)], 1.00025, atol=1e-6)


def test_a_wall_beside_a_black_box_keeps_the_sky_the_box_leaves():
    """A vertical wall (one quad, no floor) under a constant sky with a black box 0.5 before it: each texel of the
    wall's side towards the box has pi (1 - F), F its view factor to the box's faces it sees (quadrature), to within
    6 of the 256 rays and unbiased; its other side sees the whole sky, pi, to the texel sum's 0.1 %."""
    block = SceneObject("block", box((0.4, 0.8, 1.0)), Diffuse([0.0] * 3), Transform(position=[-0.3, 0.0, 0.0]))
    receiver = wall(-1.0, albedo=0.8)
    scene = scene_of([receiver, block])
    origin, u, v, normal = plane_rectangle([receiver], *plane_of(receiver))
    front, back = bake_rectangles(scene, [(origin, u, v, normal), (origin, u, v, -normal)], (24, 32), WHITE)
    points = front.texel_centres().reshape(-1, 3)
    expected = np.pi * (1.0 - view_factor(points, np.broadcast_to(normal, points.shape), rectangle_faces(block)))
    got = front.irradiance.reshape(-1, 3).mean(axis=1)
    assert expected.min() < 0.8 * np.pi  # the box takes a fifth of the sky and more before it
    assert np.abs(got - expected).max() < 6 * RAY and abs((got - expected).mean()) < 0.5 * RAY
    assert np.allclose(back.irradiance, np.pi, rtol=1e-3)


def test_a_sphere_alone_gets_the_whole_sky_and_on_a_black_floor_the_upper_half():
    """Per vertex, a diffuse sphere under a constant sky: alone, pi at every vertex (nothing occludes a convex
    object; the open irradiance in closed form); resting on a black floor 1000 wide, pi (1 + n_y) / 2 at normal n
    (the floor hides the lower half-space from every point above it; at most 2 y / 500 passes its edge, under a
    ray), within 6 rays and unbiased to a ray (the vertices within 0.05 of the floor left out: the rays start
    1e-5 of the scene's diagonal, 0.014, off the surface, under the floor there)."""
    alone = ball()
    values, baked = bake_vertices(scene_of([alone]), alone, WHITE)
    assert baked == len(values) == len(alone.mesh.vertices) and np.allclose(values, np.pi, rtol=1e-3)
    resting = ball(position=(0.0, 1.0, 0.0))
    floor = SceneObject("floor", plane((1000.0, 1000.0)), Diffuse([0.0] * 3))
    values = bake_vertices(scene_of([floor, resting]), resting, WHITE)[0].mean(axis=1)
    mesh = resting.world_mesh()
    above = mesh.vertices[:, 1] > 0.05
    expected = np.pi * (1.0 + mesh.normals[above, 1]) / 2.0
    assert np.abs(values[above] - expected).max() < 6 * RAY and abs((values[above] - expected).mean()) < RAY


def sphere_beside_wall(subdivisions: int = 3):
    """A diffuse sphere of radius 1 at the origin and a black quad wall 3 x 4 facing it at x = -1.5."""
    receiver = ball(subdivisions=subdivisions)
    return receiver, wall(-1.5), scene_of([receiver, wall(-1.5)])


def test_a_sphere_beside_a_black_wall_loses_the_walls_view_factor():
    """Each vertex of a sphere 0.5 from a black wall has pi (1 - F(p, n)), F the view factor of the wall from the
    vertex (quadrature, the wall's part below the vertex's horizon left out by the clamped cosine): within 6 rays,
    unbiased; the side facing the wall loses a third of the sky and more."""
    receiver, black, scene = sphere_beside_wall()
    values = bake_vertices(scene, receiver, WHITE)[0].mean(axis=1)
    mesh = receiver.world_mesh()
    expected = np.pi * (1.0 - view_factor(mesh.vertices.astype(np.float64), mesh.normals.astype(np.float64),
                                          rectangle_faces(black)))
    assert expected.min() < 0.7 * np.pi
    assert np.abs(values - expected).max() < 6 * RAY and abs((values - expected).mean()) < 0.5 * RAY


def test_an_ior_one_ball_changes_no_bake_and_bakes_are_bit_identical():
    """A clear ball of IOR 1 between the wall and the sphere lets every ray through unchanged: the sphere's vertices
    and the wall's maps are the bake without it (to float rounding); and a capped bake (a sphere of 10242 vertices,
    VERTEX_CAP baked) is the same bit for bit when made again."""
    receiver, black, scene = sphere_beside_wall()
    clear = ball(0.3, 3, (-1.0, 0.0, 0.0), Glass(ior=1.0), "clear")
    without = scene_bake(scene, False, 16, samples=64)
    with_ball = scene_bake(scene_of([receiver, black, clear]), False, 16, samples=64)
    assert np.allclose(with_ball.vertices[0], without.vertices[0], rtol=1e-5, atol=1e-6)
    assert all(np.allclose(a.irradiance, b.irradiance, rtol=1e-5, atol=1e-6)
               for a, b in zip(with_ball.maps, without.maps))
    fine = ball(subdivisions=5)
    first, baked = bake_vertices(scene_of([fine, black]), fine, WHITE, samples=16)
    again = bake_vertices(scene_of([ball(subdivisions=5), wall(-1.5)]), fine, WHITE, samples=16)[0]
    assert len(first) == 10242 and baked <= VERTEX_CAP and np.array_equal(first, again)


def test_a_big_mesh_is_capped_and_its_interpolated_vertices_stay_close():
    """A receiver of 81920 triangles (40962 vertices) bakes at most VERTEX_CAP vertices and the plan says so; the
    others take their baked neighbours' weighted mean: on a black floor under a constant sky every vertex is within
    4 % of pi on average of its closed form pi (1 + n_y) / 2 (64 rays a vertex)."""
    from caustica.planning.rules import plan

    big = ball(subdivisions=6, position=(0.0, 1.0, 0.0), name="big")
    floor = SceneObject("floor", plane((1000.0, 1000.0)), Diffuse([0.0] * 3))
    scene = scene_of([floor, big])
    receiver = bake_plan(scene).receivers[1]
    assert receiver.kind == "vertices" and receiver.vertices == 40962 and receiver.baked <= VERTEX_CAP
    assert f"{receiver.baked} of its 40962 vertices baked" in plan(scene).objects[1].reason
    values, baked = bake_vertices(scene, big, WHITE, samples=64)
    mesh = big.world_mesh()
    above = mesh.vertices[:, 1] > 0.05
    expected = np.pi * (1.0 + mesh.normals[above, 1]) / 2.0
    assert baked == receiver.baked
    assert np.abs(values[above].mean(axis=1) - expected).mean() < 0.04 * np.pi


def seen(scene, index: int):
    """(mask, hit points, unit normals towards the camera) of the camera's pixel centres that see object ``index``
    and whose four neighbours do too (no silhouette pixel, which the raster's coverage may give to what is behind)."""
    from caustica.raytrace.embree_scene import ray_scene_for

    origin, direction = (a.reshape(-1, 3) for a in scene.camera.primary_rays(1))
    hits = ray_scene_for(scene).intersect(origin, direction)
    normal = hits.geometric_normal * np.sign(-np.einsum("ij,ij->i", hits.geometric_normal, direction))[:, None]
    mask = (hits.hit & (hits.object_index == index)).reshape(SIZE[1], SIZE[0])
    inner = mask.copy()
    for axis in (0, 1):
        for shift in (1, -1):
            inner &= np.roll(mask, shift, axis=axis)
    return inner.reshape(-1), hits.position, normal


def planned_view(scene):
    """auto's planned parameters of the view technique for ``scene``."""
    from caustica.techniques import get_technique

    auto = get_technique("auto")
    planned = auto.for_scene(scene, auto.make_params())[1]
    return planned[0] if isinstance(planned, tuple) else planned


def test_auto_bakes_a_wall_without_a_floor(renderer):
    """No floor, the sky the only light: a wall with a black box before it. auto plans the maps and no lobes (it
    planned the lobes before: they stood in where no floor was), and the wall's pixels show its map: albedo (1 - F)
    within 3 % (the map's bilinear filter), where the unoccluded SH is 5 % off on average and 20 % before the box."""
    block = SceneObject("block", box((0.4, 0.8, 1.0)), Diffuse([0.0] * 3), Transform(position=[-0.3, 0.0, 0.0]))
    camera = Camera(position=[1.6, 0.4, 1.8], look_at=[-1.0, 0.0, 0.0], fov_y=55.0, size=SIZE)
    scene = scene_of([wall(-1.0, albedo=0.8), block], camera)
    planned = planned_view(scene)
    assert planned.environment_bake > 0 and planned.environment_lobes == 0
    on, position, normal = seen(scene, 0)
    on &= normal[:, 0] > 0.99
    assert on.sum() > 300
    expected = 0.8 * (1.0 - view_factor(position[on], normal[on], rectangle_faces(block)))
    got = renderer.render(scene, "auto").reshape(-1, 3)[on].mean(axis=1)
    assert np.abs(got / expected - 1.0).max() < 0.03
    unoccluded = renderer.render(scene, "auto", environment_bake=0, environment_lobes=0).reshape(-1, 3)[on]
    off = np.abs(unoccluded.mean(axis=1) / expected - 1.0)
    assert off.mean() > 0.05 and off.max() > 0.2


def test_auto_shows_a_spheres_vertex_bake(renderer):
    """A diffuse sphere beside a black wall, no floor: auto bakes the sphere per vertex (no lobes) and its pixels
    show albedo (1 - F(p, n)), the vertices' values interpolated across the triangles: within 2 % on average and
    6 % everywhere, where the unoccluded SH is more than 10 % off on average (seen from the wall's side)."""
    receiver, black, scene = sphere_beside_wall()
    scene.camera = Camera(position=[-0.4, 0.8, 3.6], look_at=[-0.5, 0.0, 0.0], fov_y=45.0, size=SIZE)
    planned = planned_view(scene)
    assert planned.environment_bake > 0 and planned.environment_lobes == 0
    on, position, _ = seen(scene, 0)
    assert on.sum() > 300
    radial = position[on] / np.linalg.norm(position[on], axis=1, keepdims=True)  # the smooth normal
    expected = 0.6 * (1.0 - view_factor(position[on], radial, rectangle_faces(black)))
    got = renderer.render(scene, "auto").reshape(-1, 3)[on].mean(axis=1)
    error = np.abs(got / expected - 1.0)
    assert error.mean() < 0.02 and error.max() < 0.06
    unoccluded = renderer.render(scene, "auto", environment_bake=0, environment_lobes=0).reshape(-1, 3)[on]
    assert np.abs(unoccluded.mean(axis=1) / expected - 1.0).mean() > 0.10


def test_auto_on_a_lens_before_a_chart_bakes_and_plans_no_lobes_nor_caustic_map():
    """bench_auto_cost_scenes' lens-before-chart (a thick lens before an 8 x 8 chart and two boxes, sky-checker, no
    floor): auto bakes the chart's plane and the boxes' faces instead of the lobes it planned, and no caustic map:
    of the sun's flux towards the lens 0.6 % lands on a diffuse surface (the sun lights the chart from behind; the
    lens's internal reflections reach a box), under CAUSTIC_SHARE, and the map changed no pixel."""
    from caustica.planning.probes import CAUSTIC_SHARE
    from caustica.planning.rules import plan
    from caustica.scene import procedural_environment
    from caustica.scene.presets_per_vertex import test_chart
    from caustica.scene.shapes import biconvex_lens

    lens = SceneObject("lens", biconvex_lens(0.3, 0.14, 0.01, 64, 16), Glass(ior=1.5))
    boxes = [SceneObject("box-a", box((0.2, 0.2, 0.2)), Diffuse([0.7, 0.3, 0.2]), Transform(position=[-0.45, -0.3, -0.4])),
             SceneObject("box-b", box((0.15, 0.3, 0.15)), Diffuse([0.2, 0.5, 0.7]), Transform(position=[0.45, 0.25, -0.45]))]
    camera = Camera(position=[0.12, 0.06, 0.9], look_at=[0.0, 0.0, -0.2], fov_y=38.0, size=(160, 120))
    scene = Scene(camera=camera, objects=[lens, *test_chart(center=(0.05, -0.02, -0.6), size=1.0, cells=8), *boxes],
                  environment=procedural_environment("sky-checker"))
    chosen = plan(scene)
    assert chosen.technique == "impostors"
    assert f"under {CAUSTIC_SHARE:.0%}" in chosen.describe()
    kinds = [r.kind if r else None for r in bake_plan(scene).receivers]
    assert kinds == [None] + ["plane"] * 6 + ["box", "box"] and len(bake_plan(scene).planes) == 1
    planned = planned_view(scene)
    assert planned.environment_bake > 0 and planned.environment_lobes == 0
