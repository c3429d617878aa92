"""The scene budget (scene/budget.py): limits checked before the work, stated in one-line messages."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from caustica.errors import MeshError, SceneError
from caustica.scene import budget


def fake_mesh(vertices: int, triangles: int):
    return SimpleNamespace(vertices=np.zeros((vertices, 3)), faces=np.zeros((triangles, 3)))


def test_object_limit_is_in_the_message():
    budget.check_objects(budget.MAX_OBJECTS)
    with pytest.raises(SceneError, match=f"{budget.MAX_OBJECTS:,} a scene"):
        budget.check_objects(budget.MAX_OBJECTS + 1, "x.toml has")


def test_limits_are_read_at_call_time(monkeypatch):
    monkeypatch.setattr(budget, "MAX_OBJECTS", 3)
    with pytest.raises(SceneError, match="4 objects, above the limit of 3"):
        budget.SceneBudget("x.toml").objects(4)


def test_shared_mesh_counts_its_triangles_per_object_and_its_bytes_once(monkeypatch):
    monkeypatch.setattr(budget, "MAX_SCENE_TRIANGLES", 25)
    mesh = fake_mesh(4, 10)
    totals = budget.SceneBudget("x.toml")
    totals.mesh(mesh, "objects[0]")
    totals.mesh(mesh, "objects[1]")
    assert (totals.triangles, totals.bytes) == (20, budget.mesh_bytes(4, 10))
    with pytest.raises(SceneError, match=r"x.toml's objects up to objects\[2\] hold 30 triangles in all, above"):
        totals.mesh(mesh, "objects[2]")


def test_bytes_and_file_size_raise_the_given_error(monkeypatch):
    monkeypatch.setattr(budget, "MAX_MESH_BYTES", 1000)
    with pytest.raises(MeshError, match="above the limit of 1000 bytes of mesh data"):
        budget.SceneBudget("x.toml", error=MeshError).mesh(fake_mesh(100, 1))
    with pytest.raises(MeshError, match="512 MiB a mesh file"):
        budget.check_file_size(budget.MAX_MESH_FILE_BYTES + 1, "mesh file a.obj", MeshError)
    with pytest.raises(SceneError, match="nodes, above the limit"):
        budget.check_nodes(budget.MAX_NODES + 1, "m.glb has")


def scene_file(tmp_path, objects: str, count: int):
    path = tmp_path / "many.toml"
    path.write_text('[camera]\nposition = [0, 0, 50]\n' + objects * count)
    return path


def test_too_many_objects_are_refused_before_the_toml_is_parsed(tmp_path, monkeypatch):
    import tomllib

    from caustica.scene.io import load_scene

    path = scene_file(tmp_path, '[[objects]]\nshape = "sphere"\nradius = 0.1\n', budget.MAX_OBJECTS + 1)
    monkeypatch.setattr(tomllib, "loads", lambda text: pytest.fail("parsed the file"))
    with pytest.raises(SceneError, match=f"has {budget.MAX_OBJECTS + 1:,} objects, above the limit of"):
        load_scene(path)


def test_scene_triangles_are_counted_per_object(tmp_path):
    from caustica.scene.io import load_scene

    # 3,277 default spheres (5,120 triangles each) pass MAX_SCENE_TRIANGLES at the 3,277th.
    path = scene_file(tmp_path, '[[objects]]\nshape = "sphere"\n', 3300)
    with pytest.raises(SceneError, match=r"objects up to objects\[3276\] hold 16,778,240 triangles in all"):
        load_scene(path)


def test_equal_shapes_share_one_mesh_and_load_linearly(tmp_path):
    import time

    from caustica.scene.io import load_scene

    path = scene_file(tmp_path, '[[objects]]\nshape = "sphere"\nsubdivisions = 2\n', 2000)
    start = time.perf_counter()
    scene = load_scene(path)
    assert time.perf_counter() - start < 5.0  # about 0.2 ms an object; it was 3.5 ms (a sphere built each)
    assert len({id(obj.mesh) for obj in scene.objects}) == 1
    other = load_scene(scene_file(tmp_path, '[[objects]]\nshape = "sphere"\nradius = 2\n[[objects]]\nshape = "sphere"\n', 1))
    assert other.objects[0].mesh is not other.objects[1].mesh


def test_deeply_nested_toml_is_one_line(tmp_path):
    from caustica.scene.io import load_scene

    path = tmp_path / "deep.toml"
    path.write_text("name = " + "[" * 100_000 + "]" * 100_000 + "\n")
    with pytest.raises(SceneError, match="nests arrays or inline tables too deeply"):
        load_scene(path)
