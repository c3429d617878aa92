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
    with pytest.raises(SceneError, match=r"x.toml's objects hold \(at objects\[2\]\) 30 triangles in all, above"):
        totals.mesh(mesh, "objects[2]")


def test_bytes_and_file_size_raise_the_given_error(monkeypatch):
    monkeypatch.setattr(budget, "MAX_MESH_BYTES", 1000)
    with pytest.raises(MeshError, match="above the limit of 1000 bytes of mesh data"):
        budget.SceneBudget("x.toml", error=MeshError).mesh(fake_mesh(100, 1))
    with pytest.raises(MeshError, match="512 MiB a mesh file"):
        budget.check_file_size(budget.MAX_MESH_FILE_BYTES + 1, "mesh file a.obj", MeshError)
    with pytest.raises(SceneError, match="nodes, above the limit"):
        budget.check_nodes(budget.MAX_NODES + 1, "m.glb has")
