"""Per-pixel label layers (caustica.labels, docs/labels.md) against known answers, at 64x48."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.errors import OutputError, RenderOptionError
from caustica.labels import LABELS, material_table, read_labels, write_labels
from caustica.raytrace.optics import dot, refract
from caustica.renderer import Renderer
from caustica.scene import (Camera, Diffuse, Glass, Mirror, PointLight, Scene, SceneObject, Transform,
                            procedural_environment)
from caustica.scene.environment import Environment, sky_checker
from caustica.scene.shapes import box, plane, sphere

SIZE = (64, 48)
ALL = list(LABELS)


def scene_of(objects, camera=None, lights=()) -> Scene:
    camera = camera or Camera(position=[0.0, 0.0, 5.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=SIZE)
    return Scene(camera=camera, objects=list(objects), lights=list(lights),
                 environment=procedural_environment("sky-checker"))


def wall(z: float = -2.0, name: str = "wall", material=None) -> SceneObject:
    """A 40 x 40 plane at depth z facing +Z (plane() faces +Y; rotated 90 degrees about X)."""
    return SceneObject(name, plane((40.0, 40.0)), material or Diffuse(color=[0.5, 0.5, 0.5]),
                       Transform(position=[0.0, 0.0, z], rotation=[90.0, 0.0, 0.0]))


def exact_params(**values) -> dict:
    """exact's parameters with its caustic photons off (no photon tracing: the tests of geometry stay fast)."""
    return {"caustic_photons": 0, **values}


def pixel_rays(camera: Camera):
    origins, dirs = camera.primary_rays(1)
    return origins[:, :, 0], dirs[:, :, 0]


def sphere_hits(origins, dirs, center, radius):
    """Both ray parameters on the analytic sphere (NaN off it)."""
    oc = origins - center
    b = dot(oc, dirs)
    disc = b * b - (dot(oc, oc) - radius * radius)
    with np.errstate(invalid="ignore"):
        root = np.sqrt(disc)
    return -b - root, -b + root


def silhouette(ids: np.ndarray) -> np.ndarray:
    """Pixels whose 3x3 neighbourhood holds more than one id (edges, where rasterizer and oracle may differ)."""
    padded = np.pad(ids, 1, mode="edge")
    edge = np.zeros(ids.shape, bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            edge |= padded[1 + dy : 1 + dy + ids.shape[0], 1 + dx : 1 + dx + ids.shape[1]] != ids
    return edge


# Depth, normals, ids, materials, glass -----------------------------------------------------------


@pytest.mark.parametrize("technique", ["env-map", "exact"])
def test_depth_of_a_plane_facing_the_camera_is_its_distance(renderer, technique):
    # The plane z = -2 seen from z = 5 along -Z: view-space depth 7 at every pixel (the ray length is not).
    scene = scene_of([wall(-2.0)])
    params = exact_params() if technique == "exact" else {}
    _, layers = renderer.render(scene, technique, labels=["depth", "id", "alpha"], **params)
    assert layers["depth"].shape == (48, 64) and layers["depth"].dtype == np.float32
    np.testing.assert_allclose(layers["depth"], 7.0, rtol=1e-5)
    assert (layers["id"] == 0).all() and (layers["alpha"] == 1.0).all()


def test_depth_of_a_tilted_plane_follows_the_closed_form(renderer):
    # A plane through the origin, tilted 30 degrees about X: along each pixel ray the hit is
    # t = -(o . n) / (d . n), its view depth t (d . forward).
    scene = scene_of([SceneObject("tilted", plane((40.0, 40.0)), Diffuse(), Transform(rotation=[60.0, 0.0, 0.0]))])
    normal = np.array([0.0, np.cos(np.radians(60.0)), np.sin(np.radians(60.0))])
    origins, dirs = pixel_rays(scene.camera)
    expected = -dot(origins, normal) / dot(dirs, normal) * -dirs[..., 2]
    for technique, tolerance in (("env-map", 2e-5), ("exact", 1e-6)):
        _, layers = renderer.render(scene, technique, labels=["depth"],
                                    **(exact_params() if technique == "exact" else {}))
        np.testing.assert_allclose(layers["depth"], expected, rtol=tolerance)


def test_background_depth_is_inf_and_normals_ids_materials_are_empty(renderer):
    scene = scene_of([SceneObject("ball", sphere(0.5, 4), Diffuse())])
    _, layers = renderer.render(scene, "env-map", labels=ALL)
    background = layers["id"] == -1
    assert background.sum() > 0.5 * background.size
    assert np.isinf(layers["depth"][background]).all() and np.isfinite(layers["depth"][~background]).all()
    assert (layers["normal"][background] == 0).all() and (layers["material"][background] == -1).all()
    assert (layers["alpha"][background] == 0).all() and (layers["flow_object"] == -1).all()


@pytest.mark.parametrize("technique, tolerance", [("env-map", 2e-3), ("exact", 1e-6)])
def test_normals_of_a_sphere_are_radial(renderer, technique, tolerance):
    # Rasterized: the interpolated vertex normals of the tessellation (measured 5.7e-4 at 5 subdivisions);
    # exact: the analytic sphere's radial normal (float32).
    center, radius = np.array([0.3, -0.2, 0.0]), 1.2
    scene = scene_of([SceneObject("ball", sphere(radius, 5), Diffuse(), Transform(position=center))])
    _, layers = renderer.render(scene, technique, labels=["normal", "id"],
                                **(exact_params() if technique == "exact" else {}))
    origins, dirs = pixel_rays(scene.camera)
    t0, _ = sphere_hits(origins, dirs, center, radius)
    expected = (origins + t0[..., None] * dirs - center) / radius
    inside = np.isfinite(t0) & ~silhouette(layers["id"])
    assert inside.sum() > 400 and (layers["id"][inside] == 0).all()
    got = layers["normal"][inside].astype(np.float64)
    np.testing.assert_allclose(np.linalg.norm(got, axis=1), 1.0, atol=1e-5)
    error = np.linalg.norm(got - expected[inside], axis=1)
    assert error.max() < tolerance, error.max()


def three_objects() -> Scene:
    grey = Diffuse(color=[0.5, 0.5, 0.5])
    objects = [wall(-2.0, material=grey),
               SceneObject("ball", sphere(0.6, 4), Glass(1.5), Transform(position=[-0.8, 0.0, 0.0])),
               SceneObject("cube", box((0.8, 0.8, 0.8)), Diffuse(color=[0.5, 0.5, 0.5]),
                           Transform(position=[0.9, 0.2, 0.0], rotation=[20.0, 30.0, 0.0])),
               SceneObject("mirror", sphere(0.3, 3), Mirror(), Transform(position=[0.0, -0.9, 0.5]))]
    return scene_of(objects)


def test_ids_are_object_indices_and_match_the_oracle_off_silhouettes(renderer):
    scene = three_objects()
    _, gpu = renderer.render(scene, "depth-search", labels=["id", "material", "glass"])
    _, cpu = renderer.render(scene, "exact", labels=["id", "material", "glass"], **exact_params())
    assert gpu["id"].dtype == np.int32 and set(np.unique(gpu["id"])) == {0, 1, 2, 3}
    # The pixel at the centre of each object's projection holds that object's index.
    camera = scene.camera
    clip = camera.clip_from_world()
    for index, obj in enumerate(scene.objects[1:], start=1):
        p = clip @ np.append(obj.transform.position, 1.0)
        x, y = (p[0] / p[3] * 0.5 + 0.5) * SIZE[0], (0.5 - p[1] / p[3] * 0.5) * SIZE[1]
        assert gpu["id"][int(y), int(x)] == index
    interior = ~silhouette(cpu["id"])
    np.testing.assert_array_equal(gpu["id"][interior], cpu["id"][interior])
    # Materials: the wall and the cube share one (equal fields), so 0, 1, 0, 2.
    assert [type(m).__name__ for m in material_table(scene)] == ["Diffuse", "Glass", "Mirror"]
    expected = np.array([0, 1, 0, 2])[cpu["id"]]
    np.testing.assert_array_equal(gpu["material"][interior], expected[interior])
    np.testing.assert_array_equal(cpu["material"], np.where(cpu["id"] >= 0, np.array([0, 1, 0, 2])[cpu["id"]], -1))
    # Glass: the first hit's material is glass, as the oracle's mask off silhouettes.
    np.testing.assert_array_equal(gpu["glass"][interior], cpu["glass"][interior])
    np.testing.assert_array_equal(cpu["glass"], (cpu["id"] == 1).astype(np.uint8))
    assert gpu["glass"].dtype == np.uint8 and gpu["glass"].sum() > 50


# Refractive flow ----------------------------------------------------------------------------------


def test_flow_of_an_index_one_ball_is_the_straight_ray_onto_the_wall(renderer):
    scene = scene_of([wall(-2.0), SceneObject("ball", sphere(1.0, 5), Glass(1.0))])
    _, layers = renderer.render(scene, "depth-search", labels=["flow", "glass"])
    origins, dirs = pixel_rays(scene.camera)
    glass = layers["glass"].astype(bool)
    valid = np.linalg.norm(layers["flow"], axis=-1) > 0
    assert glass.sum() > 300 and (valid <= glass).all() and valid.sum() >= glass.sum() - 2 * SIZE[0]
    np.testing.assert_allclose(layers["flow"][valid], dirs[valid], atol=1e-6)
    assert (layers["flow_object"][valid] == 0).all()
    straight = origins + ((-2.0 - origins[..., 2]) / dirs[..., 2])[..., None] * dirs
    np.testing.assert_allclose(layers["flow_point"][valid], straight[valid], atol=1e-5)
    assert (layers["flow"][~glass] == 0).all() and (layers["flow_object"][~glass] == -1).all()


@pytest.mark.parametrize("technique", ["depth-search", "exact"])
def test_flow_through_a_glass_sphere_is_the_closed_form_exit(renderer, technique):
    center, radius, ior = np.array([0.0, 0.0, 0.0]), 1.0, 1.5
    scene = scene_of([SceneObject("ball", sphere(radius, 5), Glass(ior))])
    _, layers = renderer.render(scene, technique, labels=["flow", "glass"],
                                **(exact_params() if technique == "exact" else {}))
    origins, dirs = pixel_rays(scene.camera)
    t0, _ = sphere_hits(origins, dirs, center, radius)
    on = np.isfinite(t0) & layers["glass"].astype(bool)
    # Enter: refract about the outward normal; cross the chord; leave about the inward normal.
    p1 = origins[on] + t0[on, None] * dirs[on]
    inner, tir1 = refract(dirs[on], (p1 - center) / radius, 1.0 / ior)
    _, t_exit = sphere_hits(p1, inner, center, radius)
    p2 = p1 + t_exit[:, None] * inner
    out, tir2 = refract(inner, -(p2 - center) / radius, ior)
    assert not tir1.any() and not tir2.any()
    got = layers["flow"][on]
    keep = np.linalg.norm(got, axis=1) > 0  # a tessellation silhouette pixel may miss the true sphere
    assert keep.sum() > on.sum() - 2 * SIZE[0] and on.sum() > 300
    np.testing.assert_allclose(got[keep], out[keep], atol=2e-6)
    assert (layers["flow_object"][on] == -1).all()  # nothing behind: the environment


def test_flow_under_a_water_surface_lands_on_the_floor_by_snell(renderer):
    # An open water surface (one refracting plane, IOR 1.33) at y = 0.5 over a floor at y = 0: each ray
    # refracts once, t = refract(d, +Y, 1 / 1.33), and lands at p1 + (0.5 / -t_y) t on the floor.
    water = SceneObject("water", plane((40.0, 40.0)), Glass(1.33), Transform(position=[0.0, 0.5, 0.0]))
    camera = Camera(position=[0.0, 3.0, 3.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=SIZE)
    scene = scene_of([SceneObject("floor", plane((40.0, 40.0)), Diffuse()), water], camera)
    _, layers = renderer.render(scene, "env-map", labels=["flow", "glass"])
    origins, dirs = pixel_rays(camera)
    assert layers["glass"].all()
    p1 = origins + ((0.5 - origins[..., 1]) / dirs[..., 1])[..., None] * dirs
    inside, tir = refract(dirs.reshape(-1, 3), np.array([0.0, 1.0, 0.0]), np.full(dirs.size // 3, 1.0 / 1.33))
    inside = inside.reshape(dirs.shape)
    assert not tir.any()
    landing = p1 + (0.5 / -inside[..., 1])[..., None] * inside
    np.testing.assert_allclose(layers["flow"], inside, atol=1e-6)
    assert (layers["flow_object"] == 0).all()
    np.testing.assert_allclose(layers["flow_point"], landing, atol=1e-5)


# Caustics -----------------------------------------------------------------------------------------


def ball_over_floor(lights=True, caster=True) -> Scene:
    """Without lights the sky has no sun either (the raster techniques light with the sun as a
    directional light, passes/shading/environment.py)."""
    objects = [SceneObject("floor", plane((12.0, 12.0)), Diffuse(color=[0.5, 0.5, 0.5]))]
    if caster:
        objects.append(SceneObject("ball", sphere(0.6, 5), Glass(1.5), Transform(position=[0.0, 1.2, 0.0])))
    camera = Camera(position=[0.0, 2.2, 4.2], look_at=[0.0, 0.5, 0.0], fov_y=40.0, size=SIZE)
    scene = scene_of(objects, camera, [PointLight(position=[0.0, 4.0, 0.0], intensity=[20.0, 20.0, 20.0])]
                     if lights else [])
    if not lights:
        scene.environment = Environment(sky_checker(sun_direction=None), source="test:sky-checker without its sun")
    return scene


@pytest.mark.parametrize("lights, caster", [(False, True), (True, False)])
def test_caustic_layer_is_zero_without_light_or_caster(renderer, lights, caster):
    _, layers = renderer.render(ball_over_floor(lights, caster), "depth-search+caustic-mapping", labels=["caustic"])
    assert layers["caustic"].shape == (48, 64, 3) and (layers["caustic"] == 0).all()


def test_caustic_layer_is_zero_without_a_caustic_technique(renderer):
    _, layers = renderer.render(ball_over_floor(), "depth-search", labels=["caustic"])
    assert (layers["caustic"] == 0).all()


@pytest.mark.parametrize("caustics", ["caustic-mapping", "photon-splats", "impostor-caustics"])
def test_caustic_layer_is_the_caustic_light_on_the_floor(renderer, caustics):
    # On floor pixels, image(with caustics) - image(without) = albedo / pi * caustic (ShadeSurfaces adds
    # albedo / pi * E_caustic * intensity_scale), from caustic maps or (impostor-caustics) caustic tiles;
    # the focus lies under the ball, at the floor's origin.
    scene = ball_over_floor()
    with_caustics, layers = renderer.render(scene, f"depth-search+{caustics}", labels=["caustic", "id", "depth"])
    without = renderer.render(scene, "depth-search")
    floor = layers["id"] == 0
    caustic = layers["caustic"]
    assert caustic[floor].max() > 1.0 and (caustic >= 0).all() and (caustic[~floor] == 0).all()
    expected = (with_caustics - without)[floor] * np.pi / 0.5
    np.testing.assert_allclose(caustic[floor], expected, atol=1e-6 * float(caustic.max()))
    # The brightest pixel sees the floor at the focus (the origin), found back from its depth.
    origins, dirs = pixel_rays(scene.camera)
    y, x = np.unravel_index(np.argmax(caustic[..., 0]), floor.shape)
    forward = -scene.camera.view_from_world()[2, :3]
    point = origins[y, x] + dirs[y, x] * layers["depth"][y, x] / (dirs[y, x] @ forward)
    assert np.linalg.norm(point) < 0.15, point


def test_caustic_label_refused_where_the_technique_cannot_separate_it(renderer):
    with pytest.raises(RenderOptionError, match="cannot give the caustic label"):
        renderer.render(ball_over_floor(), "mitsuba", labels=["caustic"])


def test_exact_caustic_layer_is_zero_when_it_renders_no_caustics(renderer):
    _, layers = renderer.render(ball_over_floor(), "exact", labels=["caustic"], **exact_params())
    assert (layers["caustic"] == 0).all()


def test_exact_caustic_layer_is_its_photon_estimate_on_the_floor(renderer):
    # exact adds albedo / pi * intensity_scale * E_caustic (photon map, over the pixel's footprint) where
    # an eye path ends on a diffuse surface; the layer is E_caustic * intensity_scale on the floor seen directly.
    scene = ball_over_floor()
    with_caustics, layers = renderer.render(scene, "exact", labels=["caustic", "id"], caustic_photons=100_000)
    without = renderer.render(scene, "exact", caustic_photons=0)
    floor = layers["id"] == 0
    caustic = layers["caustic"]
    assert caustic[floor].max() > 1.0 and (caustic[~floor] == 0).all()
    np.testing.assert_allclose(caustic[floor], (with_caustics - without)[floor] * np.pi / 0.5,
                               atol=1e-5 * float(caustic.max()))


# Alpha ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("technique", ["env-map", "exact"])
def test_alpha_is_coverage_fractional_at_edges_with_four_samples(renderer, technique):
    scene = scene_of([SceneObject("ball", sphere(1.0, 5), Diffuse())])
    params = exact_params() if technique == "exact" else {}
    _, one = renderer.render(scene, technique, labels=["alpha", "id"], **params)
    np.testing.assert_array_equal(one["alpha"], (one["id"] >= 0).astype(np.float32))
    _, four = renderer.render(scene, technique, spp=4, labels=["alpha", "id"], **params)
    alpha = four["alpha"]
    assert set(np.unique(alpha)) <= {0.0, 0.25, 0.5, 0.75, 1.0}
    edge = (alpha > 0) & (alpha < 1)
    assert edge.sum() > 20 and (edge <= silhouette(four["id"])).all()
    assert (alpha[~silhouette(four["id"])] == (four["id"][~silhouette(four["id"])] >= 0)).all()
    # Coverage is the ball's area in the image: pi r^2 of its projected disc, in pixels.
    assert abs(alpha.sum() - (one["id"] >= 0).sum()) < 0.05 * alpha.sum()


# Files and errors ----------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".exr", ".npz"])
def test_labels_round_trip_exactly(renderer, tmp_path, suffix):
    _, layers = renderer.render(three_objects(), "depth-search", labels=ALL)
    path = write_labels(tmp_path / f"frame{suffix}", layers)
    back = read_labels(path)
    assert set(back) == set(layers)
    for name, array in layers.items():
        assert back[name].dtype == array.dtype and back[name].shape == array.shape, name
        np.testing.assert_array_equal(back[name], array, err_msg=name)
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"frame{suffix}"]  # no temporary left


def test_exr_labels_are_a_real_multi_layer_exr_with_documented_channels(renderer, tmp_path):
    from caustica.images import read_exr_channels

    _, layers = renderer.render(three_objects(), "depth-search", labels=["id", "depth", "normal", "glass", "alpha"])
    path = write_labels(tmp_path / "labels.exr", layers)
    assert path.read_bytes()[:4] == b"\x76\x2f\x31\x01"  # the OpenEXR magic number (imageio would write TIFF)
    channels = read_exr_channels(path)
    assert sorted(channels) == ["alpha.A", "depth.Z", "glass.V", "id.V", "normal.X", "normal.Y", "normal.Z"]
    np.testing.assert_array_equal(channels["id.V"], layers["id"].astype(np.float32))
    assert channels["glass.V"].dtype == np.uint32


def test_write_labels_refuses_bad_layers_in_one_line(tmp_path):
    depth = np.ones((4, 5), np.float32)
    for layers, message in [({}, "non-empty dict"), ({"depth": depth, "id": np.ones((3, 5))}, "of one size"),
                            ({"a.b": depth}, "plain name"), ({"normal": np.ones((4, 5, 2))}, "3")]:
        with pytest.raises(OutputError, match=message) as info:
            write_labels(tmp_path / "x.exr", layers)
        assert "\n" not in str(info.value)
    with pytest.raises(OutputError, match="must end in .exr or .npz"):
        write_labels(tmp_path / "x.png", {"depth": depth})
    with pytest.raises(OutputError, match="did you mean 'npz'"):
        write_labels(tmp_path / "x.exr", {"depth": depth}, format="npy")
    assert list(tmp_path.iterdir()) == []


def test_unknown_label_is_one_line_with_the_nearest_name_and_the_list(renderer):
    scene = scene_of([wall()])
    with pytest.raises(RenderOptionError) as info:
        renderer.render(scene, "env-map", labels=["id", "dpeth"])
    message = str(info.value)
    assert "did you mean 'depth'" in message and ", ".join(LABELS) in message and "\n" not in message
    with pytest.raises(RenderOptionError, match="unknown label 3"):
        renderer.render(scene, "env-map", labels=[3])


def test_labels_leave_the_image_bit_identical(renderer):
    scene = three_objects()
    for technique, spp in (("depth-search", 1), ("depth-search+caustic-mapping", 4), ("env-map", 4)):
        plain = renderer.render(scene, technique, spp=spp)
        labelled, layers = renderer.render(scene, technique, spp=spp, labels=ALL)
        again = renderer.render(scene, technique, spp=spp)
        np.testing.assert_array_equal(labelled, plain)
        np.testing.assert_array_equal(again, plain)
        assert all(array.shape[:2] == (48, 64) for array in layers.values())


def test_empty_label_list_returns_no_layers(renderer):
    image, layers = renderer.render(scene_of([wall()]), "env-map", labels=[])
    assert layers == {} and image.shape == (48, 64, 3)


def test_labels_leave_no_texture_lent():
    """On a Renderer of its own, so that what another test leaves lent on the session's shared one cannot
    fail this test (test_impostors and test_gpu_layer did, by frames they never gave back)."""
    from caustica.gpu.device import gl_objects

    with Renderer() as renderer:
        for technique in ("depth-search+caustic-mapping", "depth-search+impostor-caustics"):
            for spp in (1, 4):
                _, layers = renderer.render(ball_over_floor(), technique, spp=spp, labels=ALL)
                device = renderer.device
                cached = sum(1 for obj in gl_objects(list(device.cache.values())) if device.targets.is_lent(obj))
                assert device.targets.counts()["lent_textures"] == cached
                assert layers["caustic"].max() > 1.0  # caustic maps and caustic tiles both reach the label


def test_material_numbering_follows_first_use_and_compares_fields():
    from caustica.labels import material_indices
    from caustica.scene.textures import checker

    texture = checker()
    blue = [0.2, 0.3, 0.4]
    materials = [Glass(1.5), Diffuse(color=blue), Glass(1.5), Glass(1.33), Diffuse(color=blue, texture=texture),
                 Diffuse(color=blue, texture=texture)]
    scene = scene_of([SceneObject(f"o{i}", sphere(0.2, 1), m) for i, m in enumerate(materials)])
    assert material_indices(scene) == [0, 1, 0, 2, 3, 3]
    assert [m.kind for m in material_table(scene)] == ["glass", "diffuse", "glass", "diffuse"]


@pytest.mark.parametrize("technique", ["image-space", "impostors", "per-vertex", "per-object"])
def test_labels_do_not_depend_on_the_technique(renderer, technique):
    # The label pass draws the scene's own geometry, whatever the technique draws the image with.
    scene = three_objects()
    _, reference = renderer.render(scene, "env-map", labels=["id", "depth", "normal", "glass"])
    _, layers = renderer.render(scene, technique, labels=["id", "depth", "normal", "glass"])
    for name in reference:
        np.testing.assert_array_equal(layers[name], reference[name], err_msg=name)
