"""Mesh files (scene/mesh_files.py): special files refused by type, glTF through caustica's own reader,
and a hypothesis fuzz of mutated OBJ, PLY, STL and OFF bytes: a mesh or one clean line, never a traceback."""
from __future__ import annotations

import os
import re
import struct
import time

import numpy as np
import pytest

from caustica.errors import CausticaError, MeshError
from caustica.scene.mesh_files import load_mesh

TRIANGLE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
FACES = [(0, 1, 2), (0, 2, 3), (0, 3, 1), (1, 3, 2)]

OBJ = ("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\n"
       "f 1/1 3/3 2/2\nf 1 4 3\nf -4 -3 -1\nf 2 3 4\n").encode()
PLY_HEADER = ("ply\nformat {} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 4\nproperty list uchar int vertex_indices\nend_header\n")
PLY_ASCII = (PLY_HEADER.format("ascii") + "".join(f"{x:g} {y:g} {z:g}\n" for x, y, z in TRIANGLE)
             + "".join(f"3 {a} {b} {c}\n" for a, b, c in FACES)).encode()
PLY_BINARY = (PLY_HEADER.format("binary_little_endian").encode() + TRIANGLE.tobytes()
              + b"".join(struct.pack("<B3i", 3, *f) for f in FACES))
STL_BINARY = (b"\0" * 80 + struct.pack("<I", 4)
              + b"".join(struct.pack("<12fH", 0, 0, 0, *TRIANGLE[list(f)].ravel(), 0) for f in FACES))
STL_ASCII = ("solid t\n" + "".join("facet normal 0 0 0\nouter loop\n" + "".join(
    f"vertex {x:g} {y:g} {z:g}\n" for x, y, z in TRIANGLE[list(f)]) + "endloop\nendfacet\n" for f in FACES)
    + "endsolid t\n").encode()
OFF = ("OFF\n4 4 0\n" + "".join(f"{x:g} {y:g} {z:g}\n" for x, y, z in TRIANGLE)
       + "".join(f"3 {a} {b} {c}\n" for a, b, c in FACES)).encode()
FILES = {".obj": OBJ, ".ply": PLY_ASCII, ".stl": STL_BINARY, ".off": OFF}
SEEDS = [(".obj", OBJ), (".ply", PLY_ASCII), (".ply", PLY_BINARY), (".stl", STL_BINARY), (".stl", STL_ASCII),
         (".off", OFF)]


@pytest.mark.parametrize("suffix, data", SEEDS, ids=["obj", "ply", "ply-binary", "stl", "stl-ascii", "off"])
def test_the_fuzz_seeds_load(suffix, data, tmp_path):
    path = tmp_path / f"t{suffix}"
    path.write_bytes(data)
    mesh = load_mesh(path)
    assert len(mesh.faces) == 4 and np.allclose(mesh.bounds, [[0, 0, 0], [1, 1, 1]])


def special_files(tmp_path):
    fifo = tmp_path / "pipe.obj"
    os.mkfifo(fifo)
    (tmp_path / "folder.ply").mkdir()
    (tmp_path / "zero.stl").symlink_to("/dev/zero")
    return {"pipe.obj": "is a named pipe (FIFO)", "folder.ply": "is a directory",
            "zero.stl": "links to /dev/zero, a character device"}


def test_special_files_are_refused_by_type_before_opening(tmp_path):
    for name, expect in special_files(tmp_path).items():
        start = time.perf_counter()
        with pytest.raises(MeshError, match=re.escape(f"{expect}, not a mesh file")):
            load_mesh(tmp_path / name)
        assert time.perf_counter() - start < 1.0


def test_special_files_in_a_scene_exit_2_in_one_line(tmp_path, capsys):
    from caustica.cli import main

    out = tmp_path / "out"
    out.mkdir()
    for name, expect in special_files(tmp_path).items():
        (tmp_path / "s.toml").write_text(f'[camera]\nsize = [16, 16]\n[[objects]]\nmesh = "{name}"\n')
        code = main(["plan", str(tmp_path / "s.toml")])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and expect in err, err
    assert list(out.iterdir()) == []


def glb(nodes: list[dict]) -> bytes:
    """A binary glTF of one triangle mesh (TRIANGLE's first three corners) drawn by ``nodes``."""
    import json

    data = TRIANGLE[:3].tobytes()
    doc = {"asset": {"version": "2.0"}, "buffers": [{"byteLength": len(data)}],
           "bufferViews": [{"buffer": 0, "byteLength": len(data)}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                          "min": [0, 0, 0], "max": [1, 1, 0]}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}], "nodes": nodes,
           "scenes": [{"nodes": list(range(len(nodes)))}]}
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    chunks = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(data), 0x004E4942) + data
    return struct.pack("<III", 0x46546C67, 2, 12 + len(chunks)) + chunks


def test_gltf_meshes_go_through_caustica_s_reader_not_trimesh(tmp_path, monkeypatch):
    import trimesh

    path = tmp_path / "two.glb"
    path.write_bytes(glb([{"mesh": 0}, {"mesh": 0, "translation": [5, 0, 0]}]))
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: pytest.fail("trimesh read a glTF"))
    mesh = load_mesh(path)
    assert len(mesh.faces) == 2  # both nodes, merged in world space
    assert np.allclose(mesh.bounds, [[0, 0, 0], [6, 1, 0]])


# Fuzz ----------------------------------------------------------------------------------

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

# Bytes that make parsers stumble: digits, signs, separators, huge counts, NUL, header words.
PIECES = st.sampled_from([b"0", b"-1", b"9", b"255", b"999999999", b"/", b" ", b"\n", b"\0", b"\xff", b"nan",
                          b"1e300", b"f ", b"v ", b"3 ", b"end_header\n", b"solid", b"element face 9\n", b"OFF\n"])
EDIT = st.tuples(st.sampled_from(["replace", "insert", "delete"]), st.floats(0, 1), st.integers(1, 12), PIECES)


def mutated(data: bytes, edits) -> bytes:
    """``data`` with each edit applied at a fraction of its length: a piece written over or inserted, or a span cut."""
    for kind, where, length, piece in edits:
        at = int(where * len(data))
        if kind == "delete":
            data = data[:at] + data[at + length:]
        else:
            data = data[:at] + piece + data[at + (len(piece) if kind == "replace" else 0):]
    return data


@settings(max_examples=300, derandomize=True, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(seed=st.sampled_from(SEEDS), edits=st.lists(EDIT, min_size=1, max_size=4))
def test_mutated_mesh_files_load_or_fail_in_one_line(seed, edits, tmp_path, capsys):
    suffix, data = seed
    path = tmp_path / f"fuzz{suffix}"
    path.write_bytes(mutated(data, edits))
    try:
        mesh = load_mesh(path)
    except CausticaError as exc:
        text = str(exc)
        assert text and "\n" not in text and len(text) <= 400, text[:500]
        assert not any(leak in text for leak in ("reshape", "index out of range", "could not be read", "Traceback"))
        return
    finally:
        assert capsys.readouterr().err == "", "the parser printed (trimesh logs tracebacks it recovers from)"
    assert len(mesh.faces) >= 1 and np.all(np.isfinite(mesh.vertices))
