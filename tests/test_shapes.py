"""Procedural shapes: closed, outward facing, analytic normals, the sizes their parameters say."""
import math

import numpy as np
import pytest
import trimesh

from caustica.scene import shapes
from caustica.scene.mesh import Mesh

CLOSED = {
    "sphere": lambda: shapes.sphere(1.0, subdivisions=3),
    "box": lambda: shapes.box((1.0, 2.0, 3.0)),
    "torus": lambda: shapes.torus(1.0, 0.3, segments=48, sides=24),
    "torus-knot": lambda: shapes.torus_knot(2, 3, segments=128, sides=12),
    "cylinder": lambda: shapes.cylinder(0.5, 2.0, segments=32),
    "biconvex-lens": lambda: shapes.biconvex_lens(1.0, 0.4, segments=48, rings=12),
    "biconvex-lens-band": lambda: shapes.biconvex_lens(1.0, 0.5, edge_thickness=0.1, segments=48, rings=12),
    "biconcave-lens": lambda: shapes.biconcave_lens(1.0, 0.1, 0.5, segments=48, rings=12),
    "lens-meniscus": lambda: shapes.lens(0.3, 0.5, 0.7, 0.08, segments=48, rings=12),
    "lens-plano-convex": lambda: shapes.lens(0.3, 0.0, -0.6, 0.1, segments=48, rings=12),
    "ring": lambda: shapes.ring(0.8, 1.0, 0.5, segments=64),
}
OPEN = {
    "plane": lambda: shapes.plane((2.0, 3.0), resolution=4),
    "water": lambda: shapes.water_heightfield((2.0, 2.0), resolution=32, amplitude=0.05),
    "open-cylinder": lambda: shapes.cylinder(0.5, 1.0, segments=16, caps=False),
}


def merged(mesh) -> trimesh.Trimesh:
    """The mesh as trimesh sees it, coincident vertices merged (hard edges become shared)."""
    return trimesh.Trimesh(mesh.vertices.astype(np.float64), mesh.faces)


def face_normals(mesh) -> np.ndarray:
    v = mesh.vertices.astype(np.float64)
    f = mesh.faces
    return np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])


@pytest.mark.parametrize("name", CLOSED)
def test_closed_shapes_are_watertight_and_outward(name):
    mesh = CLOSED[name]()
    tm = merged(mesh)
    assert tm.is_watertight and tm.is_winding_consistent
    assert tm.volume > 0  # counter-clockwise from outside encloses positive volume


@pytest.mark.parametrize("name", {**CLOSED, **OPEN})
def test_is_solid_means_closed_and_outward(name):
    mesh = {**CLOSED, **OPEN}[name]()
    assert mesh.is_solid() == (name in CLOSED) == (not mesh.is_open())


def test_is_solid_rejects_flipped_holed_and_inward_meshes():
    sphere = shapes.sphere(1.0, subdivisions=2)
    one_flipped = sphere.faces.copy()
    one_flipped[0] = one_flipped[0, ::-1]
    variants = {"one face flipped": one_flipped, "one face missing": sphere.faces[1:],
                "inward": sphere.faces[:, ::-1], "a face twice": np.vstack([sphere.faces, sphere.faces[:1]])}
    for what, faces in variants.items():
        assert not Mesh(sphere.vertices, None, faces).is_solid(), what


@pytest.mark.parametrize("name", {**CLOSED, **OPEN})
def test_vertex_normals_agree_with_winding(name):
    mesh = {**CLOSED, **OPEN}[name]()
    corner_normals = mesh.normals[mesh.faces].astype(np.float64)  # (F, 3, 3)
    geometric = face_normals(mesh)
    geometric /= np.linalg.norm(geometric, axis=1, keepdims=True)
    assert np.all(np.einsum("fj,fkj->fk", geometric, corner_normals) > 0.3)
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-6)
    assert not np.any(np.linalg.norm(face_normals(mesh), axis=1) < 1e-12), "degenerate triangles"


def test_sphere_normals_are_radial_and_volume_is_close():
    mesh = shapes.sphere(2.0, subdivisions=4)
    np.testing.assert_allclose(np.linalg.norm(mesh.vertices, axis=1), 2.0, rtol=1e-6)
    np.testing.assert_allclose(mesh.normals, mesh.vertices / 2.0, atol=1e-6)
    assert len(mesh.faces) == 20 * 4**4
    assert merged(mesh).volume == pytest.approx(4 / 3 * math.pi * 8, rel=0.01)


def test_box_volume_and_flat_normals():
    mesh = shapes.box((1.0, 2.0, 3.0))
    assert len(mesh.vertices) == 24 and len(mesh.faces) == 12
    assert merged(mesh).volume == pytest.approx(6.0)
    np.testing.assert_allclose(mesh.bounds, [[-0.5, -1, -1.5], [0.5, 1, 1.5]])
    assert set(map(tuple, np.abs(mesh.normals).round(6))) == {(1, 0, 0), (0, 1, 0), (0, 0, 1)}


def test_torus_volume_and_normals():
    mesh = shapes.torus(1.0, 0.25)
    assert merged(mesh).volume == pytest.approx(2 * math.pi**2 * 1.0 * 0.25**2, rel=0.01)
    # The normal points from the nearest point on the core circle to the vertex.
    v = mesh.vertices.astype(np.float64)
    core = v * [1, 0, 1]
    core /= np.linalg.norm(core, axis=1, keepdims=True)
    np.testing.assert_allclose(mesh.normals, (v - core) / 0.25, atol=1e-5)
    np.testing.assert_allclose(mesh.bounds[1], [1.25, 0.25, 1.25], atol=1e-6)


def test_torus_knot_tube_radius():
    mesh = shapes.torus_knot(2, 3, radius=1.0, tube_radius=0.1, segments=256, sides=16)
    # Each vertex lies tube_radius away from the curve along its normal, and the normal is
    # perpendicular to the curve there: the curve point is vertex - r * normal.
    centre = mesh.vertices - 0.1 * mesh.normals
    rings = centre.reshape(256, 16, 3)
    np.testing.assert_allclose(rings, rings[:, :1, :].repeat(16, axis=1), atol=1e-5)
    with pytest.raises(ValueError, match="coprime"):
        shapes.torus_knot(2, 4)


def test_cylinder_volume_and_caps():
    mesh = shapes.cylinder(0.5, 2.0, segments=64)
    assert merged(mesh).volume == pytest.approx(math.pi * 0.25 * 2.0, rel=0.01)
    top = mesh.normals[:, 1] > 0.5
    np.testing.assert_allclose(mesh.vertices[top, 1], 1.0)
    side = np.abs(mesh.normals[:, 1]) < 1e-6
    np.testing.assert_allclose(np.linalg.norm(mesh.vertices[side][:, [0, 2]], axis=1), 0.5, rtol=1e-6)


def test_ring_volume_and_inner_wall_faces_the_axis():
    mesh = shapes.ring(0.8, 1.0, 0.5, segments=128)
    assert merged(mesh).volume == pytest.approx(math.pi * (1.0 - 0.64) * 0.5, rel=0.01)
    radial = np.linalg.norm(mesh.vertices[:, [0, 2]], axis=1)
    wall = np.abs(mesh.normals[:, 1]) < 1e-6
    inner = wall & np.isclose(radial, 0.8)
    outward = np.einsum("ij,ij->i", mesh.normals[:, [0, 2]], mesh.vertices[:, [0, 2]])
    assert inner.any() and np.all(outward[inner] < 0) and np.all(outward[wall & ~inner] > 0)


def lens_sphere_radius(aperture, sag):
    return (aperture**2 + sag**2) / (2 * sag)


def test_biconvex_lens_matches_parameters():
    radius, thickness = 1.0, 0.4
    mesh = shapes.biconvex_lens(radius, thickness, segments=96, rings=24)
    np.testing.assert_allclose(mesh.bounds[:, 2], [-thickness / 2, thickness / 2], atol=1e-6)
    aperture = np.linalg.norm(mesh.vertices[:, :2], axis=1).max()
    assert aperture == pytest.approx(radius, abs=1e-6)
    # Front face: a sphere of radius R centred at z = s - R, normals radial from that centre.
    s = thickness / 2
    big_r = lens_sphere_radius(radius, s)
    front = mesh.normals[:, 2] > 0
    centre = np.array([0.0, 0.0, s - big_r])
    offset = mesh.vertices[front] - centre
    np.testing.assert_allclose(np.linalg.norm(offset, axis=1), big_r, rtol=1e-5)
    np.testing.assert_allclose(mesh.normals[front], offset / big_r, atol=1e-5)
    cap = math.pi * s**2 * (3 * big_r - s) / 3
    assert merged(mesh).volume == pytest.approx(2 * cap, rel=0.01)


def test_biconcave_lens_matches_parameters():
    radius, center, edge = 1.0, 0.1, 0.5
    mesh = shapes.biconcave_lens(radius, center, edge, segments=96, rings=24)
    np.testing.assert_allclose(mesh.bounds[:, 2], [-edge / 2, edge / 2], atol=1e-6)
    on_axis = np.linalg.norm(mesh.vertices[:, :2], axis=1) < 1e-9
    np.testing.assert_allclose(np.sort(mesh.vertices[on_axis, 2]), [-center / 2, center / 2], atol=1e-7)
    # Front face: concave, centre at z = center/2 + R, normals point towards that centre.
    s = (edge - center) / 2
    big_r = lens_sphere_radius(radius, s)
    front = (mesh.normals[:, 2] > 1e-6) & (mesh.vertices[:, 2] > 0)  # the rim band's normals have z = 0
    offset = np.array([0.0, 0.0, center / 2 + big_r]) - mesh.vertices[front]
    np.testing.assert_allclose(np.linalg.norm(offset, axis=1), big_r, rtol=1e-5)
    np.testing.assert_allclose(mesh.normals[front], offset / big_r, atol=1e-5)
    cap = math.pi * s**2 * (3 * big_r - s) / 3
    assert merged(mesh).volume == pytest.approx(math.pi * radius**2 * edge - 2 * cap, rel=0.01)


@pytest.mark.parametrize("front, back, thickness", [(0.5, 0.7, 0.08), (0.0, -0.6, 0.1), (-0.8, 0.8, 0.04),
                                                     (-0.5, -0.9, 0.05), (1.0, -1.0, 0.1)])
def test_lens_faces_are_the_spheres_its_radii_say(front, back, thickness):
    """shapes.lens: a face of curvature radius R (the optician's sign) through its pole p = +-thickness / 2 is the
    sphere centred at p - R on the axis, so it lies at z(r) = p - R + sign(R) sqrt(R^2 - r^2) (flat at p where R
    is 0); its normals point out of the glass (away from the centre on a convex face, towards it on a concave
    one); the volume is the integral of z_front - z_back over the aperture."""
    aperture = 0.3
    mesh = shapes.lens(aperture, front, back, thickness, segments=96, rings=24)
    v, n = mesh.vertices.astype(np.float64), mesh.normals.astype(np.float64)
    r = np.linspace(0.0, aperture, 20001)
    heights = []
    for curvature, pole, facing in ((front, thickness / 2, 1.0), (back, -thickness / 2, -1.0)):
        face = facing * n[:, 2] > 1e-6  # the rim band's normals have z = 0
        if curvature == 0.0:
            np.testing.assert_allclose(v[face, 2], pole, atol=1e-7)
            heights.append(pole + 0.0 * r)
            continue
        offset = v[face] - [0.0, 0.0, pole - curvature]
        np.testing.assert_allclose(np.linalg.norm(offset, axis=1), abs(curvature), rtol=1e-5)
        np.testing.assert_allclose(n[face], facing * offset / curvature, atol=1e-5)
        heights.append(pole - curvature + np.sign(curvature) * np.sqrt(curvature**2 - r**2))
    volume = np.trapezoid(2.0 * np.pi * r * (heights[0] - heights[1]), r)
    assert merged(mesh).volume == pytest.approx(volume, rel=0.005)


def test_lens_thickness_checks():
    with pytest.raises(ValueError, match="edge_thickness"):
        shapes.biconcave_lens(1.0, center_thickness=0.5, edge_thickness=0.2)
    with pytest.raises(ValueError, match="thickness"):
        shapes.biconvex_lens(1.0, thickness=-0.1)
    with pytest.raises(ValueError, match="hemisphere"):
        shapes.biconcave_lens(0.5, center_thickness=0.01, edge_thickness=2.0)
    with pytest.raises(ValueError, match="back_radius .* hemisphere"):
        shapes.lens(0.5, 1.0, -0.4, 0.5)
    with pytest.raises(ValueError, match="faces cross"):
        shapes.lens(0.3, 0.0, -0.6, 0.05)  # the convex back rises 0.08 to its rim, above the flat front
    with pytest.raises(ValueError, match="center_thickness"):
        shapes.lens(0.3, 1.0, 0.0, 0.0)


def test_plane_faces_up_and_has_the_size():
    mesh = shapes.plane((2.0, 3.0), resolution=2)
    assert len(mesh.vertices) == 9 and len(mesh.faces) == 8
    np.testing.assert_allclose(mesh.bounds, [[-1, 0, -1.5], [1, 0, 1.5]])
    assert np.all(face_normals(mesh)[:, 1] > 0)
    np.testing.assert_allclose(mesh.normals, np.tile([0, 1, 0], (9, 1)))


def test_water_is_deterministic_bounded_and_normals_match_the_surface():
    a = shapes.water_heightfield((2.0, 2.0), resolution=64, amplitude=0.05, seed=1, time=0.3)
    b = shapes.water_heightfield((2.0, 2.0), resolution=64, amplitude=0.05, seed=1, time=0.3)
    c = shapes.water_heightfield((2.0, 2.0), resolution=64, amplitude=0.05, seed=1, time=0.6)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    assert not np.allclose(a.vertices, c.vertices)
    assert np.abs(a.vertices[:, 1]).max() <= 0.05 + 1e-6
    assert np.abs(a.vertices[:, 1]).max() > 0.005
    assert not merged(a).is_watertight  # a single open sheet
    # Analytic normals against the smooth vertex normals of the fine grid.
    from caustica.scene.mesh import vertex_normals

    numeric = vertex_normals(a.vertices, a.faces)
    interior = np.all(np.abs(a.vertices[:, [0, 2]]) < 0.95, axis=1)
    cosines = np.einsum("ij,ij->i", numeric[interior], a.normals[interior])
    assert cosines.min() > 0.999


def test_bad_parameters_name_themselves():
    with pytest.raises(ValueError, match="radius must be positive"):
        shapes.sphere(-1.0)
    with pytest.raises(ValueError, match="subdivisions"):
        shapes.sphere(1.0, subdivisions=1.5)
    with pytest.raises(ValueError, match="minor_radius"):
        shapes.torus(1.0, 1.5)
    with pytest.raises(ValueError, match="size"):
        shapes.box((1.0, 1.0))
