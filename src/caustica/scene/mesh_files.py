"""Mesh files to one :class:`Mesh`: OBJ, PLY, STL and OFF through trimesh, glTF/GLB through caustica's own
reader (scene/gltf: one reader for glTF; trimesh never reads glTF).

Each file is checked before it is parsed: what the path is (a FIFO would block, a link to /dev/zero never
ends), its size and the counts its header declares (scene/budget.py, rules.MAX_TRIANGLES), and the counts
and indices of its format against what is really there (an STL header's triangle count against the file's
size, a PLY or OFF row against its declared length, OBJ indices against the vertices given). A file whose
triangles all have zero area is refused after parsing. Every failure is one :class:`MeshError` naming the
file, the problem and the fix, never the parser's internals.
"""
from __future__ import annotations

import logging
import re
import struct
from pathlib import Path

import numpy as np

from ..errors import MeshError
from ..input_files import check_regular_file
from . import budget, rules
from .gltf import GLTF_SUFFIXES
from .mesh import SUPPORTED_MESH_SUFFIXES, Mesh, check_faces, check_positions, vertex_normals

STL_HEADER, STL_TRIANGLE = 84, 50
PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
             "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
             "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
PLY_FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}
DEGENERATE_AREA = 1e-12  # a triangle's doubled area below this times the squared mesh size is zero
_REPAIR = "repair or re-export the file"


def load_mesh(path: str | Path) -> Mesh:
    """One mesh from an OBJ, PLY, STL, OFF or glTF/GLB file (a glTF's nodes merged in world space), with the
    file's texture coordinates where it has them; MeshError (one line) for a file that is not a valid mesh."""
    path = Path(path)
    label = f"mesh file {path}"
    check_regular_file(path, "mesh", SUPPORTED_MESH_SUFFIXES, MeshError,
                       " (relative paths are relative to the scene file)")
    suffix = path.suffix.lower()
    if suffix not in SUPPORTED_MESH_SUFFIXES:
        raise MeshError(f"unsupported mesh format '{path.suffix}' for {path}; use one of "
                        f"{', '.join(SUPPORTED_MESH_SUFFIXES)}")
    budget.check_file_size(path.stat().st_size, label, MeshError)
    if suffix in GLTF_SUFFIXES:
        return _gltf_mesh(path, label)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise MeshError(f"cannot read {label}: {exc.strerror or exc}; check its permissions") from None
    _CHECKS[suffix](data, label)
    return _trimesh_mesh(path, label)


def _gltf_mesh(path: Path, label: str) -> Mesh:
    """A glTF file's objects, placed by their nodes, merged into one mesh (uvs, and the file's tangents, where
    every part has them)."""
    from .gltf.read import read_gltf

    parts = [obj.world_mesh() for obj in read_gltf(path).objects]
    if not parts:
        raise MeshError(f"{label} holds no triangles; give a mesh with at least one triangle")
    offsets = np.cumsum([0] + [len(p.vertices) for p in parts[:-1]])
    faces = np.concatenate([p.faces + offset for p, offset in zip(parts, offsets)])
    uvs = None if any(p.uvs is None for p in parts) else np.concatenate([p.uvs for p in parts])
    tangents = None if any(p.tangents is None for p in parts) else np.concatenate([p.tangents for p in parts])
    return Mesh(np.concatenate([p.vertices for p in parts]), np.concatenate([p.normals for p in parts]), faces,
                name=path.stem, uvs=uvs, tangents=tangents)


def _trimesh_mesh(path: Path, label: str) -> Mesh:
    """The file through trimesh, unprocessed first (processing silently drops the faces of non-finite vertices)."""
    import trimesh

    quiet = logging.getLogger("trimesh")
    level, quiet.level = quiet.level, logging.CRITICAL + 1  # it logs tracebacks of what it recovers from
    try:
        loaded = trimesh.load(str(path), file_type=path.suffix.lower()[1:], force="mesh", process=False)
    except Exception:  # trimesh raises many types on malformed files, in numpy's words (not the user's)
        raise MeshError(f"cannot read {label}: its {path.suffix.lower()[1:].upper()} data is malformed (a value that "
                        f"is not a number, or rows that do not match its header); {_REPAIR}") from None
    finally:
        quiet.setLevel(level)
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshError(f"{label} holds no triangles; give a mesh with at least one triangle")
    vertices = np.asarray(loaded.vertices, dtype=np.float64)
    check_positions(vertices, label)
    check_faces(np.asarray(loaded.faces), len(vertices), label)
    check_area(vertices, np.asarray(loaded.faces), label)
    loaded.process()
    vertices = np.asarray(loaded.vertices)
    faces = np.asarray(loaded.faces)
    uv = getattr(loaded.visual, "uv", None)  # trimesh's convention, v upwards (OBJ's, PLY's)
    uvs = None
    if uv is not None and len(uv) == len(vertices):
        uv = np.asarray(uv, dtype=np.float64)
        uvs = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]])  # Mesh.uvs: v downwards from the image's top
    return Mesh(vertices, vertex_normals(vertices, faces), faces, name=path.stem, uvs=uvs)


def check_area(vertices: np.ndarray, faces: np.ndarray, label: str) -> None:
    """MeshError when every triangle has zero area (repeated corners, or corners on one line)."""
    v = np.asarray(vertices, dtype=np.float64)
    corners = v[faces]
    doubled = np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    size = float(np.ptp(v, axis=0).max())
    if not np.any(doubled > DEGENERATE_AREA * size * size):
        raise MeshError(f"{label} has only degenerate triangles (zero area: repeated corners or corners on one "
                        f"line), {len(faces):,} of them; {_REPAIR}")


def _triangles(count: int, what: str) -> None:
    """rules.triangles for the triangles a file holds or declares (``what``: "mesh file x.ply declares")."""
    rules.triangles(count, what, "use a coarser (decimated) mesh", error=MeshError)


def _text(data: bytes, label: str, suffix: str) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise MeshError(f"{label} is not UTF-8 text; save it as UTF-8 (or ASCII) {suffix}") from None


def _line(data, position: int) -> int:
    """The 1-based line number of ``position`` in ``data`` (text or bytes)."""
    return data.count("\n" if isinstance(data, str) else b"\n", 0, position) + 1


# STL ------------------------------------------------------------------------------


def _check_stl(data: bytes, label: str) -> None:
    """A binary STL's 80-byte header and triangle count must match the file's size; else ASCII ``solid``."""
    if len(data) >= STL_HEADER:
        count = struct.unpack_from("<I", data, 80)[0]
        if len(data) == STL_HEADER + STL_TRIANGLE * count:
            _triangles(count, f"{label} holds")
            return
    if data.lstrip()[:5].lower() == b"solid" and b"\0" not in data[:STL_HEADER]:
        _triangles(data.count(b"endfacet"), f"{label} holds")
        return
    if len(data) < STL_HEADER:
        raise MeshError(f"cannot read {label}: {len(data)} bytes, too short for a binary STL (84-byte header) and not ASCII "
                        f"STL (no 'solid'); {_REPAIR}")
    raise MeshError(f"cannot read {label}: its header declares {count:,} triangles ({STL_HEADER + STL_TRIANGLE * count:,} "
                    f"bytes) but has {len(data):,} bytes; the file is truncated or damaged: {_REPAIR}")


# OBJ ------------------------------------------------------------------------------

_OBJ_ELEMENT = re.compile(r"^[ \t]*(v|vt|vn)[ \t]", re.MULTILINE)
_OBJ_FACE = re.compile(r"^[ \t]*f[ \t]+([^\r\n#]*)", re.MULTILINE)
_OBJ_SHORT_VERTEX = re.compile(r"^[ \t]*v(?:[ \t]+[^\s#]+){0,2}[ \t]*(?:#.*)?$", re.MULTILINE)
_OBJ_NAMES = ("vertices", "texture coordinates", "normals")


def _check_obj(data: bytes, label: str) -> None:
    """Every face has at least three corners, and every index (1-based, or negative from the end) names a
    vertex, texture coordinate or normal the file gives."""
    text = _text(data, label, ".obj")
    short = _OBJ_SHORT_VERTEX.search(text)
    if short:
        raise MeshError(f"{label} has no vertices of three coordinates at line {_line(text, short.start())} "
                        f"({short.group(0).strip()[:30]!r}); give every v line x y z: {_REPAIR}")
    kinds = _OBJ_ELEMENT.findall(text)
    counts = [kinds.count(k) for k in ("v", "vt", "vn")]
    triangles = 0
    for match in _OBJ_FACE.finditer(text):
        corners = match.group(1).split()
        if len(corners) < 3:
            raise MeshError(f"cannot read {label}: line {_line(text, match.start())}: a face of {len(corners)} corners; a face "
                            f"needs at least three; {_REPAIR}")
        triangles += len(corners) - 2
        for corner in corners:
            for index, count, name in zip(corner.split("/"), counts, _OBJ_NAMES):
                if index == "" and name != "vertices":
                    continue
                problem = _obj_index_problem(index, count, name)
                if problem:
                    raise MeshError(f"cannot read {label}: line {_line(text, match.start())}: {problem}; {_REPAIR}")
    _triangles(triangles, f"{label} holds")


def _obj_index_problem(index: str, count: int, name: str) -> str | None:
    """What is wrong with one OBJ face index, or None."""
    try:
        value = int(index)
    except ValueError:
        return f"face index {index[:20]!r} is not a whole number"
    if value == 0:
        return "face index 0 (OBJ indices count from 1, or from -1 backwards)"
    if not -count <= value <= count:
        return f"face index {value} but the file has {count:,} {name}"
    return None


# PLY and OFF: rows of numbers ---------------------------------------------------------


def _check_ply(data: bytes, label: str) -> None:
    """The header's elements and properties, their counts within the budget, and the body holding every
    row the header declares, each list as long as its count says."""
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise MeshError(f"cannot read {label}: not a PLY file (no 'ply' ... 'end_header' header); {_REPAIR}")
    body = data.find(b"\n", end) + 1 or len(data)
    try:
        header = data[:end].decode("ascii").splitlines()
    except UnicodeDecodeError:
        raise MeshError(f"cannot read {label}: its PLY header is not ASCII text; {_REPAIR}") from None
    order, elements = _ply_header(header, label)
    counts = {name: count for name, count, _ in elements}
    _triangles(counts.get("face", 0), f"{label} declares")
    vertices = counts.get("vertex", 0)
    budget.check_bytes(budget.mesh_bytes(vertices, counts.get("face", 0)),
                       f"{label} declares {vertices:,} vertices, which take", MeshError)
    if order is None:
        _ply_ascii_rows(data[body:].decode("ascii", "replace").splitlines(), elements, label)
    else:
        _ply_binary_rows(memoryview(data)[body:], elements, order, label)


def _ply_header(lines: list[str], label: str):
    """(byte order or None for ascii, [(element, count, [property types: 'f4' or ('list', count, item)])])."""
    order, elements = "?", []
    for number, line in enumerate(lines, 1):
        words = line.split()
        if not words or words[0] in ("ply", "comment", "obj_info"):
            continue
        if words[0] == "format" and len(words) >= 2 and words[1] in PLY_FORMATS:
            order = PLY_FORMATS[words[1]]
        elif words[0] == "element" and len(words) == 3 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements and len(words) == 3 and words[1] in PLY_TYPES:
            elements[-1][2].append(PLY_TYPES[words[1]])
        elif (words[0] == "property" and elements and len(words) == 5 and words[1] == "list"
              and words[2] in PLY_TYPES and words[3] in PLY_TYPES and PLY_TYPES[words[2]][0] in "iu"):
            elements[-1][2].append(("list", PLY_TYPES[words[2]], PLY_TYPES[words[3]]))
        else:
            raise MeshError(f"cannot read {label}: header line {number} {line.strip()[:40]!r} is not valid PLY; {_REPAIR}")
    if order == "?":
        raise MeshError(f"cannot read {label}: no valid 'format' line (ascii, binary_little_endian or binary_big_endian); "
                        f"{_REPAIR}")
    return order, elements


def _ply_ascii_rows(lines: list[str], elements, label: str) -> None:
    rows = iter(line.split() for line in lines if line.strip())
    for name, count, properties in elements:
        for row in range(count):
            values = next(rows, None)
            if values is None:
                raise MeshError(f"cannot read {label}: it declares {count:,} {name} rows and holds {row:,}; the file is truncated: "
                                f"{_REPAIR}")
            _ascii_row(values, properties, f"cannot read {label}: {name} {row}")


def _ascii_row(values: list[str], properties, where: str) -> None:
    """One ascii PLY row against its properties: one value each, a list its count and that many items."""
    used = 0
    for prop in properties:
        if isinstance(prop, tuple):
            declared = values[used] if used < len(values) else ""
            if not declared.isdigit():
                raise MeshError(f"{where} has a list count {declared[:20]!r} that is not a whole number; {_REPAIR}")
            length = int(declared)
            if used + 1 + length > len(values):
                raise MeshError(f"{where} declares {length} indices and gives {len(values) - used - 1}; {_REPAIR}")
            used += 1 + length
        else:
            used += 1
    if used != len(values):
        raise MeshError(f"{where} has {len(values)} values where its properties take {used}; {_REPAIR}")


def _ply_binary_rows(body: memoryview, elements, order: str, label: str) -> None:
    """Walk a binary body: fixed rows by size, list rows by their counts (all at once where equal)."""
    position = 0
    for name, count, properties in elements:
        if not any(isinstance(p, tuple) for p in properties):
            position += count * sum(np.dtype(p).itemsize for p in properties)
        else:
            position = _binary_list_rows(body, position, count, properties, order, f"{label}: {name}")
        if position > len(body):
            raise MeshError(f"cannot read {label}: it declares {count:,} {name} rows, more than its {len(body):,} bytes of data "
                            f"hold; the file is truncated or its header wrong: {_REPAIR}")


def _binary_list_rows(body: memoryview, position: int, count: int, properties, order: str, where: str) -> int:
    """The end of ``count`` rows with list properties starting at ``position`` (past the body when short)."""
    sizes = [(np.dtype(order + p[1]), np.dtype(p[2]).itemsize) if isinstance(p, tuple) else (None, np.dtype(p).itemsize)
             for p in properties]
    first = _binary_row_end(body, position, sizes)
    if first is None:
        return len(body) + 1
    width = first - position
    if len(sizes) == 1 and position + width * count <= len(body):  # one list: equal rows checked at once
        counts = np.ndarray((count,), sizes[0][0], body, position, (width,))
        if np.all(counts == counts[0]):
            return position + width * count
    for _ in range(count):
        position = _binary_row_end(body, position, sizes)
        if position is None:
            return len(body) + 1
    return position


def _binary_row_end(body: memoryview, position: int, sizes) -> int | None:
    for count_type, item in sizes:
        if count_type is None:
            position += item
            continue
        if position + count_type.itemsize > len(body):
            return None
        length = int(np.frombuffer(body, count_type, 1, position)[0])
        position += count_type.itemsize + length * item
    return position if position <= len(body) else None


def _check_off(data: bytes, label: str) -> None:
    """``OFF`` (or ``COFF``), the counts line, then every vertex row (three numbers) and face row (a count
    of at least three and that many indices) the counts declare."""
    text = _text(data, label, ".off")
    lines = [line.split("#", 1)[0].split() for line in text.splitlines()]
    lines = [words for words in lines if words]
    if not lines or lines[0][0] not in ("OFF", "COFF"):
        raise MeshError(f"cannot read {label}: it does not start with 'OFF'; {_REPAIR}")
    header = lines[0][1:] or (lines[1] if len(lines) > 1 else [])
    body = lines[2:] if not lines[0][1:] else lines[1:]
    if len(header) < 2 or not all(word.isdigit() for word in header[:2]):
        raise MeshError(f"cannot read {label}: no vertex and face count line after 'OFF'; {_REPAIR}")
    vertices, faces = int(header[0]), int(header[1])
    _triangles(faces, f"{label} declares")
    budget.check_bytes(budget.mesh_bytes(vertices, faces), f"{label} declares {vertices:,} vertices, which take",
                       MeshError)
    if len(body) < vertices + faces:
        raise MeshError(f"cannot read {label}: it declares {vertices:,} vertices and {faces:,} faces and holds {len(body):,} rows; "
                        f"the file is truncated or its counts wrong: {_REPAIR}")
    for row, words in enumerate(body[:vertices]):
        if len(words) < 3:
            raise MeshError(f"cannot read {label}: vertex {row} has {len(words)} numbers, not three; {_REPAIR}")
    for row, words in enumerate(body[vertices:vertices + faces]):
        declared = int(words[0]) if words[0].isdigit() else -1
        if declared < 3 or len(words) - 1 < declared:
            raise MeshError(f"cannot read {label}: face {row} declares {words[0][:20]!r} indices and gives {len(words) - 1}; "
                            f"a face needs a count of at least three and that many indices; {_REPAIR}")
        wrong = next((word for word in words[1:declared + 1] if not word.isdigit() or int(word) >= vertices), None)
        if wrong is not None:
            raise MeshError(f"cannot read {label}: face {row} has index {wrong[:20]!r}, not one of its {vertices:,} "
                            f"vertices (0 to {vertices - 1:,}); {_REPAIR}")


_CHECKS = {".obj": _check_obj, ".ply": _check_ply, ".stl": _check_stl, ".off": _check_off}
