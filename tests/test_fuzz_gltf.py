"""Property-based fuzzing of glTF import (and export of what loads): a Blender-made .glb with its JSON
mutated (values of other types, counts, offsets and indices far off, keys deleted, values nested deep)
either loads, and then exports, or fails with one line of a caustica.errors type. Fixed seed and bounded
examples, as tests/test_fuzz.py: a few seconds."""
from __future__ import annotations

import base64
import json
import struct
import warnings
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, event, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from caustica import CausticaError  # noqa: E402
from caustica.scene.gltf.container import GLB_BIN, GLB_JSON  # noqa: E402
from caustica.scene.io import export_scene, load_scene  # noqa: E402

SOURCE = Path(__file__).resolve().parent / "data" / "gltf" / "blender-glass-ball.glb"


def fuzz(examples: int) -> settings:
    return settings(max_examples=examples, derandomize=True, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


def glb_parts(path: Path) -> tuple[dict, bytes]:
    """The JSON document and the BIN chunk of a .glb."""
    data = path.read_bytes()
    length, kind = struct.unpack_from("<II", data, 12)
    assert kind == GLB_JSON
    doc = json.loads(data[20:20 + length])
    blob_length, blob_kind = struct.unpack_from("<II", data, 20 + length)
    assert blob_kind == GLB_BIN
    return doc, data[28 + length:28 + length + blob_length]


DOC, BLOB = glb_parts(SOURCE)
DOC_EMBEDDED = json.loads(json.dumps(DOC))  # the same as .gltf, its buffer a data URI
DOC_EMBEDDED["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(BLOB).decode()


def paths(value, prefix=()):
    """Every JSON path in ``value`` (dict keys and list indices), the root excluded."""
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, child in items:
        yield prefix + (key,)
        yield from paths(child, prefix + (key,))


PATHS = sorted(paths(DOC), key=repr)
OFFSETS = st.sampled_from([-1, 0, 1, 3, 4, 35, 36, 2 ** 31, 2 ** 32 + 4, 10 ** 12, 2 ** 63, 10 ** 400])
HOSTILE = st.one_of(
    OFFSETS, st.floats(allow_nan=True, allow_infinity=True), st.booleans(), st.none(), st.text(max_size=6),
    st.sampled_from(["VEC3", "SCALAR", "MAT4", "point", "perspective", "OPAQUE", "BLEND", "data:,", "../x.bin",
                     "KHR_materials_volume", "KHR_draco_mesh_compression"]),
    st.lists(st.integers(-2, 12), max_size=5), st.just({}), st.just([]), st.just([0.0] * 16),
    st.sampled_from([5120, 5121, 5122, 5123, 5125, 5126, 4, 0, 6]),
)


@st.composite
def mutation(draw):
    """(operation, path, value): replace, delete, nest (wrap in 1 to 3000 lists) or duplicate a value."""
    operation = draw(st.sampled_from(["replace", "replace", "replace", "delete", "nest", "duplicate"]))
    path = draw(st.sampled_from(PATHS))
    value = draw(HOSTILE) if operation == "replace" else draw(st.sampled_from([1, 2, 50, 3000]))
    return operation, path, value


def mutated(base: dict, changes) -> str:
    """The JSON text of ``base`` with ``changes`` made (deep nesting spliced into the text: the json module
    cannot write it)."""
    doc = json.loads(json.dumps(base))
    nested = {}
    for operation, path, value in changes:
        parent = doc
        try:
            for key in path[:-1]:
                parent = parent[key]
            old = parent[path[-1]]
        except (KeyError, IndexError, TypeError):
            continue  # an earlier change removed or replaced the path
        if operation == "replace":
            parent[path[-1]] = value
        elif operation == "delete":
            del parent[path[-1]]
        elif operation == "nest":
            marker = f"nested-{len(nested)}"
            nested[marker] = "[" * value + json.dumps(old) + "]" * value
            parent[path[-1]] = marker
        elif isinstance(old, list):  # duplicate: the array's entries repeated
            parent[path[-1]] = old * min(value, 50)
    text = json.dumps(doc)
    for marker, replacement in nested.items():
        text = text.replace(json.dumps(marker), replacement)
    return text


def glb(text: str, blob: bytes) -> bytes:
    """A GLB of JSON ``text`` and ``blob``, as glb_bytes writes one."""
    data = text.encode("utf-8")
    data += b" " * (-len(data) % 4)
    blob += b"\0" * (-len(blob) % 4)
    return b"".join([b"glTF", struct.pack("<II", 2, 28 + len(data) + len(blob)), struct.pack("<II", len(data), GLB_JSON),
                     data, struct.pack("<II", len(blob), GLB_BIN), blob])


@fuzz(100)
@given(changes=st.lists(mutation(), min_size=1, max_size=3), binary=st.booleans())
def test_mutated_gltf_loads_or_fails_in_one_line(tmp_path, changes, binary):
    if binary:
        path = tmp_path / "fuzz.glb"
        path.write_bytes(glb(mutated(DOC, changes), BLOB))
    else:
        path = tmp_path / "fuzz.gltf"
        path.write_text(mutated(DOC_EMBEDDED, changes))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            scene = load_scene(path)
        except CausticaError as exc:
            event(f"refused: {type(exc).__name__}")
            assert "\n" not in str(exc) and str(exc).strip(), repr(exc)
            return
        event("loaded")
        try:
            export_scene(scene, tmp_path / "back.glb")
        except CausticaError as exc:
            assert "\n" not in str(exc), repr(exc)
            return
    load_scene(tmp_path / "back.glb")  # what caustica wrote it reads back
