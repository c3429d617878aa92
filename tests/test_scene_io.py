"""TOML scene files and presets: every key parses, every bad input is one clear line."""
from pathlib import Path

import numpy as np
import pytest

from caustica.errors import EnvironmentImageError, MeshError, SceneError
from caustica.images import write_image
from caustica.scene import DirectionalLight, Diffuse, Glass, LineLight, Mirror, PointLight, SpotLight
from caustica.scene.camera import fov_y_from_fov_x
from caustica.scene.io import load_scene
from caustica.scene.presets import PRESETS, preset_names

MODELS = Path(__file__).resolve().parents[2] / "shared" / "data" / "models"


def scene_file(tmp_path: Path, text: str, name: str = "scene.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def load_text(tmp_path: Path, text: str):
    return load_scene(scene_file(tmp_path, text))


def error_of(tmp_path: Path, text: str, kind=SceneError) -> str:
    """The one-line message ``kind`` carries when the scene ``text`` loads."""
    with pytest.raises(kind) as info:
        load_text(tmp_path, text)
    message = str(info.value)
    assert "\n" not in message and message
    return message


def write_obj(path: Path, text: str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n") -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


# Parsing -----------------------------------------------------------------------


def test_every_field_parses(tmp_path):
    write_obj(tmp_path / "models" / "tri.obj")
    env = np.full((8, 16, 3), 0.5, np.float32)
    write_image(tmp_path / "env.exr", env)
    scene = load_text(tmp_path, """
name = "everything"
intensity_scale = 2.5
[camera]
position = [0, 1, 5]
look_at = [0, 0.5, 0]
up = [0, 1, 0]
fov_y = 35
near = 0.1
far = 50
size = [320, 200]
[environment]
file = "env.exr"
[[lights]]
type = "point"
position = [0, 4, 0]
intensity = [40, 30, 20]
[[lights]]
type = "directional"
direction = [0, -1, 0]
intensity = 3
[[lights]]
type = "spot"
position = [0, 3, 0]
direction = [0, -1, 0]
intensity = 10
inner_angle = 10
outer_angle = 20
[[lights]]
type = "line"
start = [-1, 3, 0]
end = [1, 3, 0]
intensity = 8
samples = 4
[[objects]]
name = "ball"
shape = "sphere"
radius = 0.5
subdivisions = 2
position = [0, 1, 0]
rotation = [0, 45, 0]
scale = 2.0
material = { type = "glass", ior = 1.52, absorption_color = [0.9, 0.8, 0.7], absorption_distance = 2.0, abbe = 58 }
[[objects]]
shape = "plane"
size = [10, 8]
material = { type = "diffuse", color = [0.8, 0.7, 0.6] }
[[objects]]
shape = "box"
size = [1, 2, 3]
center = [2, 0, 0]
scale = [1, 2, 3]
material = { type = "mirror", color = 0.9 }
[[objects]]
shape = "torus"
major_radius = 1
minor_radius = 0.25
material = { type = "water" }
[[objects]]
shape = "torus-knot"
p = 3
q = 2
radius = 1
tube_radius = 0.1
[[objects]]
shape = "cylinder"
radius = 0.5
height = 1
[[objects]]
shape = "biconvex-lens"
radius = 1
thickness = 0.3
[[objects]]
shape = "biconcave-lens"
radius = 1
center_thickness = 0.1
edge_thickness = 0.4
[[objects]]
shape = "lens"
radius = 0.25
front_radius = 0.5
back_radius = 0.8
center_thickness = 0.05
[[objects]]
shape = "water"
size = [4, 4]
resolution = 16
amplitude = 0.1
seed = 3
time = 0.5
[[objects]]
shape = "ring"
inner_radius = 0.8
outer_radius = 1
height = 0.4
[[objects]]
mesh = "models/tri.obj"
""")
    assert scene.name == "everything" and scene.intensity_scale == 2.5
    cam = scene.camera
    np.testing.assert_allclose(cam.position, [0, 1, 5])
    np.testing.assert_allclose(cam.look_at, [0, 0.5, 0])
    assert (cam.fov_y, cam.near, cam.far, cam.size) == (35.0, 0.1, 50.0, (320, 200))
    assert scene.environment.source.endswith("env.exr")
    np.testing.assert_allclose(scene.environment.image, 0.5)

    point, directional, spot, line = scene.lights
    assert isinstance(point, PointLight) and isinstance(directional, DirectionalLight)
    assert isinstance(spot, SpotLight) and isinstance(line, LineLight)
    np.testing.assert_allclose(point.intensity, [40, 30, 20])
    np.testing.assert_allclose(directional.intensity, [3, 3, 3])
    assert (spot.inner_angle, spot.outer_angle) == (10.0, 20.0)
    assert line.samples == 4

    names = [o.name for o in scene.objects]
    assert names == ["ball", "plane", "box", "torus", "torus-knot", "cylinder", "biconvex-lens", "biconcave-lens",
                     "lens", "water", "ring", "tri"]
    ball = scene.objects[0]
    assert isinstance(ball.material, Glass) and ball.material.ior == 1.52 and ball.material.abbe == 58.0
    np.testing.assert_allclose(ball.material.absorption_color, [0.9, 0.8, 0.7])
    assert ball.material.absorption_distance == 2.0
    np.testing.assert_allclose(ball.transform.position, [0, 1, 0])
    np.testing.assert_allclose(ball.transform.rotation, [0, 45, 0])
    np.testing.assert_allclose(ball.transform.scale, [2, 2, 2])
    np.testing.assert_allclose(np.linalg.norm(ball.mesh.vertices, axis=1), 0.5, rtol=1e-6)
    plane = scene.objects[1]
    assert isinstance(plane.material, Diffuse)
    np.testing.assert_allclose(plane.mesh.bounds[:, [0, 2]], [[-5, -4], [5, 4]])
    box = scene.objects[2]
    assert isinstance(box.material, Mirror)
    np.testing.assert_allclose(box.transform.position, [2, 0, 0])
    np.testing.assert_allclose(box.transform.scale, [1, 2, 3])
    np.testing.assert_allclose(box.mesh.bounds[1], [0.5, 1.0, 1.5])
    assert isinstance(scene.objects[3].material, Glass) and scene.objects[3].material.ior == 1.33
    assert isinstance(scene.objects[4].material, Diffuse)  # default material
    assert len(scene.objects[11].mesh.faces) == 1
    # The meniscus: its front pole at +0.025, its concave back's rim lowest, at -0.025 - 0.8 + sqrt(0.8^2 - 0.25^2).
    np.testing.assert_allclose(scene.objects[8].mesh.bounds[:, 2], [-0.825 + np.sqrt(0.64 - 0.0625), 0.025], atol=1e-6)


def test_defaults_and_procedural_environment(tmp_path):
    scene = load_text(tmp_path, '[environment]\nprocedural = "white"\n')
    assert scene.name == "scene" and scene.objects == [] and scene.lights == []
    assert scene.camera.fov_y == 40.0 and scene.camera.size == (512, 512)
    assert scene.environment.source == "procedural:white"
    assert load_text(tmp_path, "").environment.source == "procedural:sky-checker"


def test_fov_x_converts_to_vertical(tmp_path):
    scene = load_text(tmp_path, "[camera]\nfov_x = 60\nsize = [800, 400]\n")
    assert scene.camera.fov_y == pytest.approx(fov_y_from_fov_x(60.0, 800, 400))
    assert scene.camera.fov_x == pytest.approx(60.0)
    assert scene.camera.fov_y < 60.0


def test_mesh_path_is_relative_to_the_scene_file(tmp_path, monkeypatch):
    write_obj(tmp_path / "scenes" / "models" / "tri.obj")
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    scene = load_scene(scene_file(tmp_path / "scenes", '[[objects]]\nmesh = "models/tri.obj"\n'))
    assert scene.objects[0].name == "tri"


def test_same_mesh_twice_gets_distinct_names(tmp_path):
    write_obj(tmp_path / "tri.obj")
    scene = load_text(tmp_path, '[[objects]]\nmesh = "tri.obj"\n[[objects]]\nmesh = "tri.obj"\n')
    assert [o.name for o in scene.objects] == ["tri", "tri-1"]
    assert scene.objects[0].mesh is scene.objects[1].mesh


@pytest.mark.skipif(not (MODELS / "suzanne.obj").exists(), reason="shared models not available")
def test_shared_model_loads(tmp_path):
    scene = load_text(tmp_path, f'[[objects]]\nmesh = "{MODELS / "suzanne.obj"}"\nmaterial = "glass"\n')
    assert len(scene.objects[0].mesh.faces) > 500


# Presets -----------------------------------------------------------------------


@pytest.mark.parametrize("name", preset_names())
def test_presets_load(name):
    from caustica.scene.preset_parts import shared_data_dir

    try:
        scene = load_scene(name)
    except SceneError as exc:
        if not shared_data_dir().is_dir():
            pytest.skip(f"{name} needs the shared data: {exc}")
        raise
    assert scene.name == name and scene.objects
    assert scene.camera.size == (512, 512)
    assert scene.environment.source.startswith("procedural:")  # presets need no files but shared meshes


def test_glass_sphere_preset():
    scene = load_scene("glass-sphere")
    (obj,) = scene.objects
    assert isinstance(obj.material, Glass) and obj.material.ior == 1.5 and scene.lights == []
    np.testing.assert_allclose(np.linalg.norm(obj.mesh.vertices, axis=1), 1.0, rtol=1e-6)


def test_caustic_sphere_focuses_near_the_floor():
    """The paraxial image of the light through the ball lies just below the floor (spherical
    aberration pulls the tightest spot up onto it): f = nR / (2(n-1)), 1/d + 1/d' = 1/f."""
    scene = load_scene("caustic-sphere")
    ball = next(o for o in scene.objects if isinstance(o.material, Glass))
    (light,) = scene.lights
    radius = float(np.linalg.norm(ball.mesh.vertices, axis=1).max())
    n = ball.material.ior
    f = n * radius / (2 * (n - 1))
    centre = ball.transform.position
    d = light.position[1] - centre[1]
    image_distance = f * d / (d - f)
    assert centre[1] <= image_distance <= 1.2 * centre[1]
    assert {"glass-sphere", "caustic-sphere"} <= set(PRESETS)  # the foundation presets; later issues add more


# Errors ------------------------------------------------------------------------


def test_missing_scene_file(tmp_path):
    with pytest.raises(SceneError, match="not found") as info:
        load_scene(tmp_path / "missing.toml")
    assert "missing.toml" in str(info.value)


def test_unknown_preset_suggests_the_nearest():
    with pytest.raises(SceneError) as info:
        load_scene("glass-sphre")
    message = str(info.value)
    assert "unknown preset 'glass-sphre'" in message and "did you mean 'glass-sphere'" in message
    assert "caustica presets" in message  # 40-odd presets: point to the list rather than print it


def test_toml_syntax_error_names_the_line(tmp_path):
    message = error_of(tmp_path, "[camera]\nposition = [0, 0, 4]\nfov_y = = 3\n")
    assert "line 3" in message and "scene.toml" in message


@pytest.mark.parametrize("text, expected", [
    ("[[objects]]\nshape = 'sphere'\nradiu = 1\n", "unknown key 'radiu' in objects[0] (did you mean 'radius'?)"),
    ("[camera]\nfov = 40\n", "unknown key 'fov' in camera"),
    ("[[object]]\nshape = 'sphere'\n", "unknown key 'object'"),
    ("[[lights]]\ntype = 'point'\nposition = [0, 1, 0]\nintensty = 3\n", "unknown key 'intensty' in lights[0]"),
    ("[[objects]]\nshape = 'box'\nmaterial = { type = 'glass', iorr = 1.5 }\n",
     "unknown key 'iorr' in objects[0].material"),
    ("[environment]\nfiles = 'a.exr'\n", "unknown key 'files' in environment"),
    ("[[objects]]\nmesh = 'a.obj'\nradius = 1\n", "unknown key 'radius' in objects[0]"),
])
def test_unknown_keys(tmp_path, text, expected):
    assert expected in error_of(tmp_path, text)


@pytest.mark.parametrize("text, expected", [
    ("[[objects]]\nshape = 'box'\n[[objects]]\nshape = 'sphere'\nposition = 'abc'\n",
     "objects[1].position must be three numbers"),
    ("[camera]\nposition = [0, 0]\n", "camera.position must be three numbers"),
    ("[camera]\nsize = [512.5, 512]\n", "camera.size must be two integers"),
    ("[[objects]]\nshape = 'sphere'\nsubdivisions = 2.5\n", "objects[0].subdivisions must be an integer"),
    ("[[objects]]\nshape = 'sphere'\nradius = true\n", "objects[0].radius must be a finite number"),
    ("[[lights]]\ntype = 'point'\nposition = [0, 1, 0]\nintensity = 'bright'\n", "lights[0].intensity must be"),
    ("name = 3\n", "name must be a string"),
    ("camera = 3\n", "camera must be a table"),
    ("objects = 3\n", "objects must be an array of tables"),
    ("[[objects]]\nshape = 'sphere'\nmaterial = 3\n", "objects[0].material must be a table"),
])
def test_wrong_types(tmp_path, text, expected):
    assert expected in error_of(tmp_path, text)


@pytest.mark.parametrize("text, expected", [
    ("[[objects]]\nshape = 'sphere'\nradius = -1\n", "objects[0].radius must be positive"),
    ("[[objects]]\nshape = 'sphere'\nradius = 0\n", "radius must be positive"),
    ("[[objects]]\nshape = 'plane'\nsize = [2, 0]\n", "objects[0].size must be positive"),
    ("[[objects]]\nshape = 'box'\nsize = -1\n", "size must be positive"),
    ("[[objects]]\nshape = 'ring'\ninner_radius = 1.2\n", "inner_radius"),
    ("[[objects]]\nshape = 'sphere'\nscale = [1, 0, 1]\n", "objects[0].scale [1.0, 0.0, 1.0] must be positive"),
    ("[[objects]]\nshape = 'sphere'\nmaterial = { type = 'glass', ior = 0 }\n",
     "objects[0].material.ior 0.0 must be a number in [0.1, 10]"),
    ("[[objects]]\nshape = 'sphere'\nmaterial = { type = 'glass', ior = -1.5 }\n", "ior"),
    ("[camera]\nsize = [0, 512]\n", "camera.size [0, 512] must lie between 1 and 16384"),
    ("[camera]\nsize = [20000, 512]\n", "between 1 and 16384"),
    ("[camera]\nfov_x = 40\nfov_y = 40\n", "both fov_x and fov_y"),
    ("[camera]\nfov_y = 200\n", "camera: field of view 200.0"),
    ("[camera]\nnear = 10\nfar = 1\n", "camera.near 10 and far 1 must satisfy 0 < near < far"),
    ("intensity_scale = 0\n", "intensity_scale 0.0 must be a number in (0, 1e+12]"),
    ("[[lights]]\ntype = 'point'\n", "lights[0] needs 'position'"),
    ("[[lights]]\ntype = 'laser'\n", "lights[0] type 'laser' is unknown"),
    ("[[lights]]\nposition = [0, 1, 0]\n", "lights[0] needs a type"),
    ("[[lights]]\ntype = 'spot'\nposition = [0, 1, 0]\n",
     "lights[0]: a spot light needs exactly one of direction or look_at"),
    ("[[lights]]\ntype = 'spot'\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\ninner_angle = 50\nouter_angle = 40\n",
     "lights[0]: spot angles"),
    ("[[objects]]\nshape = 'spher'\n", "objects[0].shape 'spher' is unknown (did you mean 'sphere'?)"),
    ("[[objects]]\nposition = [0, 0, 0]\n", "objects[0] needs exactly one of shape"),
    ("[[objects]]\nshape = 'sphere'\nmaterial = { type = 'glas' }\n", "did you mean 'glass'"),
    ("[[objects]]\nshape = 'sphere'\ncenter = [0, 0, 0]\nposition = [0, 0, 0]\n", "both center and position"),
    ("[[objects]]\nshape = 'sphere'\nname = 'a'\n[[objects]]\nshape = 'box'\nname = 'a'\n", "objects[1].name 'a'"),
    ("[environment]\nprocedural = 'skye'\n", "environment.procedural 'skye' is unknown"),
    ("[environment]\nprocedural = 'white'\nfile = 'a.exr'\n", "both file and procedural"),
])
def test_bad_values(tmp_path, text, expected):
    assert expected in error_of(tmp_path, text)


def test_mesh_errors(tmp_path):
    message = error_of(tmp_path, "[[objects]]\nmesh = 'models/none.obj'\n", MeshError)
    assert "none.obj" in message and "not found" in message
    (tmp_path / "shape.xyz").write_text("1 2 3\n")
    message = error_of(tmp_path, "[[objects]]\nmesh = 'shape.xyz'\n", MeshError)
    assert "unsupported mesh format '.xyz'" in message
    write_obj(tmp_path / "empty.obj", "# nothing here\n")
    assert "empty.obj" in error_of(tmp_path, "[[objects]]\nmesh = 'empty.obj'\n", MeshError)
    write_obj(tmp_path / "nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")
    assert "NaN" in error_of(tmp_path, "[[objects]]\nmesh = 'nan.obj'\n", MeshError)


def test_environment_errors(tmp_path):
    message = error_of(tmp_path, "[environment]\nfile = 'sky.exr'\n", EnvironmentImageError)
    assert message.startswith("environment: ") and "sky.exr" in message
    (tmp_path / "broken.exr").write_bytes(b"not an exr at all")
    message = error_of(tmp_path, "[environment]\nfile = 'broken.exr'\n", EnvironmentImageError)
    assert "broken.exr" in message


def test_scene_file_not_utf8(tmp_path):
    (tmp_path / "bad.toml").write_bytes(b"name = '\xff\xfe'\n")
    with pytest.raises(SceneError, match="UTF-8"):
        load_scene(tmp_path / "bad.toml")


def test_world_mesh_follows_a_transform_changed_in_place():
    """SceneObject caches its world-space mesh; an edit of the transform or the mesh must not leave it stale."""
    from caustica.scene import SceneObject
    from caustica.scene.materials import Diffuse
    from caustica.scene.shapes import sphere

    obj = SceneObject("ball", sphere(1.0, 2), Diffuse())
    first = obj.world_mesh()
    assert obj.world_mesh() is first  # cached while nothing changes
    obj.transform.position = np.array([5.0, 0.0, 0.0])
    moved = obj.world_mesh()
    assert np.allclose(moved.bounds.mean(axis=0), [5.0, 0.0, 0.0], atol=1e-5)
    obj.mesh = sphere(2.0, 2)
    assert np.isclose(obj.world_mesh().bounds[1, 1], 2.0, atol=1e-5)
