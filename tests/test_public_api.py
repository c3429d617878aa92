"""The scripting API on ``caustica``: lazy exports, Camera.orbited, Scene.with_camera / orbited /
replace_object, scene_from_dict."""
import subprocess
import sys

import numpy as np
import pytest

import caustica
from caustica import SceneError


def test_every_public_name_resolves_and_import_stays_light():
    for name in caustica.__all__:
        assert getattr(caustica, name) is not None, name
    assert set(caustica.__all__) <= set(dir(caustica))
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        caustica.nope
    # A fresh interpreter: importing caustica pulls in neither numpy nor the GL stack.
    code = "import sys, caustica; print(sorted(m for m in ('numpy', 'moderngl', 'pathlib') if m in sys.modules))"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout == "[]\n"


def test_exports_are_the_scene_modules_classes():
    from caustica.scene import Camera, Glass, Scene, SceneObject

    assert (caustica.Camera, caustica.Scene, caustica.SceneObject, caustica.Glass) == (Camera, Scene, SceneObject, Glass)


def test_orbit_turns_about_look_at_counter_clockwise_from_above():
    camera = caustica.Camera(position=[0.0, 1.0, 4.0], look_at=[0.0, 1.0, 0.0], size=(8, 8))
    turned = camera.orbited(90.0)
    np.testing.assert_allclose(turned.position, [4.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_array_equal(turned.look_at, camera.look_at)
    np.testing.assert_allclose(turned.up, [0.0, 1.0, 0.0], atol=1e-12)
    assert list(camera.position) == [0.0, 1.0, 4.0] and turned.size == (8, 8)  # the original is untouched
    # A full turn in 36 steps comes home; a vector axis and a named one agree; center moves look_at too.
    home = camera
    for _ in range(36):
        home = home.orbited(10.0)
    np.testing.assert_allclose(home.position, camera.position, atol=1e-9)
    np.testing.assert_allclose(camera.orbited(30.0, axis=[0, 5, 0]).position, camera.orbited(30.0).position, atol=1e-12)
    about_origin = camera.orbited(180.0, axis="x", center=[0.0, 0.0, 0.0])
    np.testing.assert_allclose(about_origin.look_at, [0.0, -1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(about_origin.up, [0.0, -1.0, 0.0], atol=1e-12)


@pytest.mark.parametrize("args, message", [((float("nan"),), "angle nan"), ((10.0, "w"), "axis 'w'"),
                                           ((10.0, [0, 0, 0]), "non-zero"), ((10.0, "y", [1, 2]), "center")])
def test_bad_orbits_are_scene_errors(args, message):
    with pytest.raises(SceneError, match=message):
        caustica.Camera().orbited(*args)


def test_batch_orbit_is_the_camera_orbit(tmp_path):
    from caustica.batch.edits import SceneEditor

    scene = caustica.load_scene("glass-sphere")
    edited = SceneEditor(scene).apply({"camera.orbit": 75.0}).camera
    np.testing.assert_allclose(edited.position, scene.camera.orbited(75.0).position, atol=1e-12)


def test_with_camera_and_orbited_share_the_rest():
    scene = caustica.load_scene("caustic-sphere")
    camera = caustica.Camera(position=[1.0, 2.0, 3.0], size=(16, 16))
    moved = scene.with_camera(camera)
    assert moved.camera is camera and moved.objects == scene.objects and moved.environment is scene.environment
    assert scene.camera is not camera
    np.testing.assert_allclose(scene.orbited(45.0).camera.position, scene.camera.orbited(45.0).position)
    with pytest.raises(SceneError, match="camera \\(a str\\) must be a caustica.Camera"):
        scene.with_camera("front")


def test_replace_object_by_name_or_index():
    scene = caustica.load_scene("caustic-sphere")
    ball = scene.objects[0]
    mirror = caustica.SceneObject("ball", ball.mesh, caustica.Mirror(), ball.transform)
    for key in ("ball", 0, -2):
        swapped = scene.replace_object(key, mirror)
        assert swapped.objects[0] is mirror and swapped.objects[1] is scene.objects[1]
    assert scene.objects[0] is ball
    with pytest.raises(SceneError, match="no object 'bal' \\(did you mean 'ball'\\?\\); give one of: 'ball', 'floor'"):
        scene.replace_object("bal", mirror)
    with pytest.raises(SceneError, match="index 2 is out of range"):
        scene.replace_object(2, mirror)
    with pytest.raises(SceneError, match="must be an object's name"):
        scene.replace_object(1.0, mirror)
    with pytest.raises(SceneError, match="new_object \\(a Mirror\\) must be a caustica.SceneObject"):
        scene.replace_object("ball", caustica.Mirror())


def test_scene_from_dict_reads_the_scene_file_format():
    scene = caustica.scene_from_dict({
        "name": "dict", "camera": {"position": [0, 1, 4], "size": [32, 24]},
        "objects": [{"name": "ball", "shape": "sphere", "radius": 0.5, "material": {"type": "glass", "ior": 1.4}}],
        "lights": [{"type": "point", "position": [0, 3, 0], "intensity": 5}],
    })
    assert isinstance(scene, caustica.Scene) and scene.name == "dict" and scene.camera.size == (32, 24)
    assert scene.objects[0].material.ior == 1.4 and isinstance(scene.lights[0], caustica.PointLight)
    assert caustica.scene_from_dict({}, name="empty").name == "empty"
    with pytest.raises(SceneError, match="objects\\[0\\].radius"):
        caustica.scene_from_dict({"objects": [{"shape": "sphere", "radius": -1}]})
    with pytest.raises(SceneError, match="must be a dict .* not a list"):
        caustica.scene_from_dict([])
