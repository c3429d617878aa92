"""Blender-made glTF through caustica and back (issue 43): tests/data/gltf/*.glb were written by Blender 5.0.1's
own exporter (scripts/make_blender_gltf.py). Import then export keeps names, doubleSided, the extensions read
and extensionsRequired; caustica adds no extras the file did not have; the environment comes back; glass
without KHR_materials_volume is said once in the plan. With Blender at hand (``import bpy``, or
CAUSTICA_BPY_PYTHON naming a Python that has it) the exported file is imported into Blender too."""
from __future__ import annotations

import dataclasses
import json
import os
import struct
import subprocess
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from caustica.errors import SceneError
from caustica.planning.rules import plan
from caustica.scene import budget
from caustica.scene.environment import procedural_environment
from caustica.scene.io import export_scene, load_scene

DATA = Path(__file__).resolve().parent / "data" / "gltf"
BLENDER_FILES = sorted(DATA.glob("blender-*.glb"))


def glb_json(path: Path) -> dict:
    """The JSON chunk of a .glb."""
    data = path.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + length])


def quiet_load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scene(path)


def round_trip(source: Path, out: Path) -> dict:
    """``source`` loaded and exported to ``out`` (.gltf); its JSON."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        export_scene(load_scene(source), out)
    return json.loads(out.read_text())


def lights(doc: dict) -> list[dict]:
    return doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])


def material_summary(doc: dict) -> list[tuple]:
    return [(m.get("name"), m.get("doubleSided", False), sorted(m.get("extensions", {}))) for m in doc["materials"]]


def test_there_are_blender_files():
    assert [p.name for p in BLENDER_FILES] == ["blender-glass-ball.glb", "blender-materials.glb",
                                               "blender-two-materials.glb"]
    assert all(p.stat().st_size < 200_000 for p in BLENDER_FILES)
    assert all(glb_json(p)["asset"]["generator"].startswith("Khronos glTF Blender I/O") for p in BLENDER_FILES)


@pytest.mark.parametrize("source", BLENDER_FILES, ids=lambda p: p.stem)
def test_blender_file_round_trip_keeps_names_sides_and_extensions(tmp_path, source):
    before = glb_json(source)
    after = round_trip(source, tmp_path / "out.gltf")
    assert material_summary(after) == material_summary(before)
    assert [(light["name"], light["type"]) for light in lights(after)] == \
        [(light["name"], light["type"]) for light in lights(before)]
    assert [c["name"] for c in after["cameras"]] == [c["name"] for c in before["cameras"]]
    assert sorted(n["name"] for n in after["nodes"]) == sorted(n["name"] for n in before["nodes"])
    meshes = {n["name"]: (d["meshes"][n["mesh"]]["name"], len(d["meshes"][n["mesh"]]["primitives"]))
              for d in (before, after) for n in d["nodes"] if "mesh" in n}
    assert meshes == {n["name"]: (before["meshes"][n["mesh"]]["name"], len(before["meshes"][n["mesh"]]["primitives"]))
                      for n in before["nodes"] if "mesh" in n}
    assert after.get("extensionsRequired") == before.get("extensionsRequired")
    assert set(after["extensionsUsed"]) == set(before["extensionsUsed"])
    # No extras the file did not have: Blender wrote none on its camera, nor on the document.
    assert "extras" not in after["cameras"][0] and "extras" not in after
    assert after["cameras"][0]["perspective"]["aspectRatio"] == before["cameras"][0]["perspective"]["aspectRatio"]


def test_carried_extension_data_is_unchanged(tmp_path):
    source = DATA / "blender-materials.glb"
    before = {m["name"]: m for m in glb_json(source)["materials"]}
    after = {m["name"]: m for m in round_trip(source, tmp_path / "out.gltf")["materials"]}
    assert after["Shiny Paint"]["extensions"]["KHR_materials_specular"] == \
        before["Shiny Paint"]["extensions"]["KHR_materials_specular"]
    assert "doubleSided" not in after["One Sided"] and after["Two Sided"]["doubleSided"] is True


def test_thin_walled_glass_stays_thin_walled_and_the_plan_says_it_once(tmp_path):
    """Blender's glass has no KHR_materials_volume: export adds none, and the plan has one line naming it."""
    source = DATA / "blender-glass-ball.glb"
    after = round_trip(source, tmp_path / "ball.gltf")
    glass = next(m for m in after["materials"] if m["name"] == "Clear Glass")
    assert set(glass["extensions"]) == {"KHR_materials_transmission", "KHR_materials_ior"}
    for scene in (quiet_load(source), quiet_load(tmp_path / "ball.gltf")):
        notes = [n for n in plan(scene).notes if "KHR_materials_volume" in n]
        assert len(notes) == 1 and "'Ball'" in notes[0] and "thin-walled" in notes[0] and "\n" not in notes[0]
        assert "'Floor'" not in notes[0]


def test_glass_with_volume_has_no_thin_walled_note(tmp_path):
    """caustica's own glass is written with KHR_materials_volume: read back, no note."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        export_scene(load_scene("caustics-point"), tmp_path / "point.glb")
    assert not [n for n in plan(quiet_load(tmp_path / "point.glb")).notes if "KHR_materials_volume" in n]


def test_camera_extras_only_where_the_user_changed_them(tmp_path):
    source = DATA / "blender-glass-ball.glb"
    scene = quiet_load(source)
    scene.camera = dataclasses.replace(scene.camera, size=(320, 180))
    export_scene(scene, tmp_path / "resized.gltf")
    camera = json.loads((tmp_path / "resized.gltf").read_text())["cameras"][0]
    assert camera["extras"]["caustica"] == {"size": [320, 180]}
    assert camera["perspective"]["aspectRatio"] == pytest.approx(320 / 180)
    assert camera["name"] == "Main Camera"
    assert quiet_load(tmp_path / "resized.gltf").camera.size == (320, 180)


def test_environment_comes_back_with_one_warning_line(tmp_path):
    scene = quiet_load(DATA / "blender-glass-ball.glb")
    scene.environment = procedural_environment("sky-checker").rotated(40.0).scaled(0.5)
    scene.intensity_scale = 3.0  # the lights carry it in glTF; the environment's strength carries it here
    with pytest.warns(UserWarning) as seen:
        export_scene(scene, tmp_path / "env.glb")
    messages = [str(w.message) for w in seen]
    assert len(messages) == 1 and "\n" not in messages[0]
    assert "extras.caustica" in messages[0] and "other glTF readers" in messages[0]
    assert glb_json(tmp_path / "env.glb")["extras"]["caustica"]["environment"] == \
        {"procedural": "sky-checker", "rotation": 40.0, "strength": 1.5}
    back = quiet_load(tmp_path / "env.glb")
    assert (back.environment.rotation, back.environment.strength, back.intensity_scale) == (40.0, 1.5, 1.0)
    np.testing.assert_allclose(back.environment.image, scene.environment.image * 3.0, rtol=1e-5)


def test_default_environment_writes_nothing(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        export_scene(quiet_load(DATA / "blender-materials.glb"), tmp_path / "plain.glb")
    assert "extras" not in glb_json(tmp_path / "plain.glb")


def flat_nodes(path: Path, count: int, mesh_every: int = 0) -> Path:
    """A .gltf with ``count`` nodes under one root, each moved a little; every ``mesh_every``-th draws a triangle."""
    triangle = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes()
    import base64

    nodes = [{"name": "root", "children": list(range(1, count))}]
    nodes += [{"name": f"n{i}", "translation": [i * 1e-3, 0.0, 0.0]} for i in range(1, count)]
    for node in nodes[1::mesh_every] if mesh_every else nodes[1:2]:
        node["mesh"] = 0
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": nodes,
           "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,"
                        + base64.b64encode(triangle).decode()}],
           "bufferViews": [{"buffer": 0, "byteLength": 36}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}]}
    path.write_text(json.dumps(doc, separators=(",", ":")))
    return path


def test_200k_nodes_load_in_seconds(tmp_path):
    """Loading is linear: 200,000 nodes took about 3 ms each (11 minutes); now about 2 s on a quiet core."""
    path = flat_nodes(tmp_path / "many.gltf", 200_000)
    start = time.perf_counter()
    scene = quiet_load(path)
    assert time.perf_counter() - start < 15.0
    assert len(scene.objects) == 1


def test_object_and_node_budgets_are_checked_before_meshes_are_built(tmp_path, monkeypatch):
    path = flat_nodes(tmp_path / "objects.gltf", 12_001, mesh_every=1)
    start = time.perf_counter()
    with pytest.raises(SceneError, match=r"objects.gltf has 12,000 objects, above the limit of 10,000"):
        load_scene(path)
    assert time.perf_counter() - start < 5.0
    monkeypatch.setattr(budget, "MAX_NODES", 1000)
    with pytest.raises(SceneError, match=r"has 12,001 nodes, above the limit of 1,000"):
        load_scene(path)


def test_triangles_of_instances_count_against_the_scene_budget(tmp_path, monkeypatch):
    """A mesh drawn by N nodes counts N times (each instance is drawn and traced)."""
    monkeypatch.setattr(budget, "MAX_SCENE_TRIANGLES", 50)
    with pytest.raises(SceneError, match=r"51 triangles in all, above the limit of 50"):
        load_scene(flat_nodes(tmp_path / "instances.gltf", 100, mesh_every=1))


BLENDER_IMPORT = """
import json, sys
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=sys.argv[-1])
print(json.dumps({
    "objects": sorted((o.name, o.type) for o in bpy.data.objects),
    "lights": sorted(light.name for light in bpy.data.lights),
    "cameras": sorted(c.name for c in bpy.data.cameras),
    "materials": sorted((m.name, m.use_backface_culling) for m in bpy.data.materials),
    "specular_tint": sorted([round(v, 3) for v in m.node_tree.nodes["Principled BSDF"].inputs["Specular Tint"]
                             .default_value] for m in bpy.data.materials if m.use_nodes),
}))
"""


def blender_import(path: Path) -> dict:
    """What Blender makes of ``path``: its objects, lights, cameras and materials (in-process bpy, or the
    Python that CAUSTICA_BPY_PYTHON names); skips without Blender."""
    python = os.environ.get("CAUSTICA_BPY_PYTHON")
    if python is None:
        pytest.importorskip("bpy")
        import sys

        python = sys.executable
    done = subprocess.run([python, "-c", BLENDER_IMPORT, str(path)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("source", BLENDER_FILES, ids=lambda p: p.stem)
def test_blender_reads_the_round_trip_as_it_read_its_own_file(tmp_path, source):
    if os.environ.get("CAUSTICA_BPY_PYTHON") is None:
        pytest.importorskip("bpy")
    round_trip(source, tmp_path / "out.gltf")
    assert blender_import(tmp_path / "out.gltf") == blender_import(source)


def test_file_environment_beside_the_output_comes_back(tmp_path):
    from PIL import Image

    from caustica.scene.environment import load_environment

    codes = (np.arange(4 * 8 * 3).reshape(4, 8, 3) * 2).astype(np.uint8)
    Image.fromarray(codes, "RGB").save(tmp_path / "sky.png")
    scene = quiet_load(DATA / "blender-glass-ball.glb")
    scene.environment = load_environment(tmp_path / "sky.png").rotated(90.0)
    with pytest.warns(UserWarning, match="kept in extras.caustica"):
        export_scene(scene, tmp_path / "with-file.glb")
    assert glb_json(tmp_path / "with-file.glb")["extras"]["caustica"]["environment"] == \
        {"file": "sky.png", "rotation": 90.0}
    np.testing.assert_allclose(quiet_load(tmp_path / "with-file.glb").environment.image, scene.environment.image)
    # Elsewhere the file is not named (the reader takes only files beside the glTF): said, not written.
    (tmp_path / "elsewhere").mkdir()
    with pytest.warns(UserWarning, match="environment .* is not kept"):
        export_scene(scene, tmp_path / "elsewhere" / "without.glb")
    assert "extras" not in glb_json(tmp_path / "elsewhere" / "without.glb")


def test_cli_plan_says_thin_walled_once_and_export_keeps_names(tmp_path, capsys):
    from caustica.cli import main

    assert main(["plan", str(DATA / "blender-glass-ball.glb")]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if "KHR_materials_volume" in line]
    assert len(lines) == 1 and "'Ball'" in lines[0]
    assert main(["export", str(DATA / "blender-materials.glb"), "-o", str(tmp_path / "out.gltf")]) == 0
    written = json.loads((tmp_path / "out.gltf").read_text())
    assert [light["name"] for light in lights(written)] == ["Rim Spot", "Sun"]


def test_a_node_of_two_primitives_comes_back_as_one_node(tmp_path):
    """Blender's two-material cube is one node of two primitives: caustica draws two objects ('Twotone.0',
    'Twotone.1') and writes one node again, unless they no longer share one place."""
    source = DATA / "blender-two-materials.glb"
    scene = quiet_load(source)
    assert [o.name for o in scene.objects] == ["Twotone.0", "Twotone.1"]
    after = round_trip(source, tmp_path / "out.gltf")
    node = next(n for n in after["nodes"] if "mesh" in n)
    assert node["name"] == "Twotone" and len(after["meshes"][node["mesh"]]["primitives"]) == 2
    moved = scene.objects[1].moved(dataclasses.replace(scene.objects[1].transform, position=[1.0, 0.5, 0.0]))
    scene.objects[1] = moved
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        export_scene(scene, tmp_path / "apart.gltf")
    apart = json.loads((tmp_path / "apart.gltf").read_text())
    assert sorted(n["name"] for n in apart["nodes"] if "mesh" in n) == ["Twotone.0", "Twotone.1"]


def test_an_environment_glTF_cannot_name_is_said_and_not_written(tmp_path):
    from caustica.scene.environment import Environment

    scene = quiet_load(DATA / "blender-glass-ball.glb")
    for source in ("made in Python", "procedural:mine", "procedural:sky-checker*dim"):
        scene.environment = Environment(np.full((4, 8, 3), 0.5, np.float32), source=source)
        with pytest.warns(UserWarning, match="environment .* is not kept"):
            export_scene(scene, tmp_path / "env.glb")
        assert "extras" not in glb_json(tmp_path / "env.glb")
