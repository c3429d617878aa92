"""The untrusted-file layer of glTF import: the JSON document, its buffers, accessors and images.

A ``.glb`` is checked chunk by chunk against its own header; a ``.gltf`` is UTF-8 JSON. Buffer and
image URIs are ``data:`` URIs or paths inside the glTF's folder; anything else (``..``, an absolute
path, ``http:`` or any other scheme) is refused, so reading a file never touches the network or a
file outside its folder. Every size an accessor or image declares is checked against the bytes that
are really there before anything is allocated. Each failure is one :class:`SceneError` (geometry:
:class:`MeshError`) naming the file, the element (``accessors[3]``) and the fix.
"""
from __future__ import annotations

import base64
import binascii
import json
import math
import re
import struct
import sys
import urllib.parse
from pathlib import Path

import numpy as np

from ...errors import MeshError, SceneError, first_line, short
from .. import rules

GLB_MAGIC = b"glTF"
GLB_JSON, GLB_BIN = 0x4E4F534A, 0x004E4942
COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
COMPONENT_TYPES = {5120: "<i1", 5121: "<u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")
_FIX = "re-export the file"
_FLOAT_MAX = sys.float_info.max


class GltfFile:
    """One glTF document with lazy access to its buffers (checked once) and typed getters whose errors
    name ``where.key``."""

    def __init__(self, path: Path, doc: dict, binary: memoryview | None):
        self.path, self.doc, self.binary = path, doc, binary
        self.folder = path.parent.resolve()
        self._buffers: dict[int, memoryview] = {}
        self._checked: dict[str, list[dict]] = {}  # top-level arrays whose entries were checked once

    # Errors and JSON values ------------------------------------------------------

    def error(self, message: str, kind=SceneError) -> Exception:
        return kind(f"{self.path.name}: {message}")

    def items(self, name: str) -> list[dict]:
        """The top-level array ``name`` (``nodes``, ``meshes``...), each entry a JSON object (checked once)."""
        checked = self._checked.get(name)
        if checked is not None:
            return checked
        value = self.doc.get(name, [])
        if not isinstance(value, list) or not all(isinstance(item, dict) for item in value):
            raise self.error(f"'{name}' must be an array of objects; {_FIX}")
        self._checked[name] = value
        return value

    def item(self, name: str, index, where: str) -> dict:
        """Entry ``index`` of the top-level array ``name``, the index checked (``where`` names the reference)."""
        items = self.items(name)
        if not _is_index(index) or index >= len(items):
            raise self.error(f"{where} {short(index)} does not index '{name}' ({len(items)} entries); {_FIX}")
        return items[index]

    def number(self, obj: dict, key: str, default: float, where: str, low: float = -np.inf,
               high: float = np.inf) -> float:
        value = obj.get(key, default)
        if not (rules.finite(value) and low <= float(value) <= high):
            raise self.error(f"{where}.{key} {short(value)} must be a number in [{low:g}, {high:g}]; {_FIX}")
        return float(value)

    def numbers(self, obj: dict, key: str, count: int, default, where: str) -> np.ndarray:
        value = obj.get(key, default)
        if not (isinstance(value, list) and len(value) == count and all(map(_json_finite, value))):
            raise self.error(f"{where}.{key} must be {count} numbers (got {short(value)}); {_FIX}")
        return np.array(value, dtype=np.float64)

    def table(self, obj: dict, key: str, where: str) -> dict:
        value = obj.get(key, {})
        if not isinstance(value, dict):
            raise self.error(f"{where}.{key} must be a JSON object; {_FIX}")
        return value

    def name(self, obj: dict, fallback: str) -> str:
        value = obj.get("name")
        return value if isinstance(value, str) and value.strip() else fallback

    # Buffers ----------------------------------------------------------------------

    def buffer(self, index: int, where: str) -> memoryview:
        """The bytes of buffer ``index``: at least its byteLength, from the GLB chunk, a data URI or a file."""
        entry = self.item("buffers", index, where)
        if index not in self._buffers:
            here = f"buffers[{index}]"
            length = entry.get("byteLength")
            if not _is_index(length) or length < 1:
                raise self.error(f"{here}.byteLength {short(length)} must be a positive integer; {_FIX}")
            if "uri" in entry:
                data = self.resource(entry["uri"], here, length)
            elif index == 0 and self.binary is not None:
                data = self.binary
            else:
                raise self.error(f"{here} has no uri and no GLB binary chunk holds it; {_FIX}")
            if len(data) < length:
                raise self.error(f"{here} is short: {len(data):,} bytes where its byteLength says {length:,}; "
                                 f"{_FIX} or restore the missing data")
            self._buffers[index] = memoryview(data)[:length]
        return self._buffers[index]

    def resource(self, uri, where: str, limit: int | None = None) -> bytes:
        """What a buffer or image ``uri`` names: a data URI's bytes, or a file inside the glTF's folder
        (at most ``limit`` bytes of it read)."""
        if not isinstance(uri, str) or not uri:
            raise self.error(f"{where}.uri {short(uri)} must be a non-empty string; {_FIX}")
        if uri.startswith("data:"):
            return self._data_uri(uri, where)
        if _SCHEME.match(uri):
            raise self.error(f"{where}.uri {short(uri)} names a remote or non-file resource; caustica reads only "
                             "files beside the glTF and data: URIs (download it and refer to it by a relative path)")
        relative = urllib.parse.unquote(uri).replace("\\", "/")  # no separator in a URI, but one on Windows
        if "\x00" in relative:
            raise self.error(f"{where}.uri {short(uri)} holds a NUL byte; {_FIX}")
        try:
            path = (self.folder / relative).resolve()
        except (OSError, RuntimeError) as exc:  # a name too long, a symlink loop
            raise self.error(f"{where}.uri {short(uri)} cannot be resolved ({first_line(exc)}); {_FIX}") from None
        if relative.startswith(("/", "\\")) or Path(relative).is_absolute() or not path.is_relative_to(self.folder):
            raise self.error(f"{where}.uri {short(uri)} leaves the glTF's folder; caustica reads only files inside "
                             f"{self.folder.name}/ (copy it there and use a relative path)")
        try:
            with open(path, "rb") as handle:
                return handle.read(limit) if limit is not None else handle.read()
        except FileNotFoundError:
            raise self.error(f"{where}.uri: file {short(relative)} not found beside {self.path.name}; "
                             "copy it there or re-export with embedded data") from None
        except OSError as exc:
            raise self.error(f"{where}.uri: cannot read {short(relative)}: {exc.strerror or first_line(exc)}; "
                             "check the file beside the glTF, or re-export with embedded data") from None

    def _data_uri(self, uri: str, where: str) -> bytes:
        head, comma, payload = uri.partition(",")
        if not comma:
            raise self.error(f"{where}.uri is a data URI without a comma before its data; {_FIX}")
        try:
            if head.endswith(";base64"):
                return base64.b64decode(payload, validate=True)
            return urllib.parse.unquote_to_bytes(payload)
        except (binascii.Error, ValueError) as exc:
            raise self.error(f"{where}.uri is a data URI that does not decode ({first_line(exc)}); {_FIX}") from None

    def buffer_view(self, index, where: str) -> tuple[memoryview, int | None]:
        """The bytes of bufferView ``index`` (its range checked against its buffer) and its byteStride."""
        view = self.item("bufferViews", index, where)
        here = f"bufferViews[{index}]"
        data = self.buffer(view.get("buffer"), f"{here}.buffer")
        offset, length = view.get("byteOffset", 0), view.get("byteLength")
        if not (_is_index(offset) and _is_index(length) and length >= 1):
            raise self.error(f"{here} needs an integer byteOffset >= 0 and byteLength >= 1; {_FIX}")
        if offset + length > len(data):
            raise self.error(f"{here} (bytes {offset:,} to {offset + length:,}) runs past the end of its buffer "
                             f"({len(data):,} bytes); {_FIX}")
        stride = view.get("byteStride")
        if stride is not None and not (_is_index(stride) and 4 <= stride <= 252):
            raise self.error(f"{here}.byteStride {short(stride)} must be an integer in [4, 252]; {_FIX}")
        return data[offset:offset + length], stride

    # Accessors --------------------------------------------------------------------

    def accessor(self, index, where: str, types: tuple[str, ...], components: tuple[int, ...]) -> np.ndarray:
        """Accessor ``index`` as an (count, n) array (float32 for float and normalized data, else its integer
        type); ``types`` (e.g. ("VEC3",)) and ``components`` (component type codes) are what the caller takes.
        The accessor's byte range is checked against its bufferView before any allocation."""
        acc = self.item("accessors", index, where)
        here = f"accessors[{index}] ({where})"
        kind, component, count = acc.get("type"), acc.get("componentType"), acc.get("count")
        if kind not in types:
            raise self.error(f"{here} has type {short(kind)} where {' or '.join(types)} is needed; {_FIX}", MeshError)
        if component not in components:
            names = ", ".join(COMPONENT_TYPES[c][1:] for c in components)
            raise self.error(f"{here} has componentType {short(component)} where one of {names} "
                             f"({', '.join(map(str, components))}) is needed; {_FIX}", MeshError)
        if not _is_index(count) or count < 1:
            raise self.error(f"{here}.count {short(count)} must be a positive integer; {_FIX}", MeshError)
        if "sparse" in acc:
            raise self.error(f"{here} is sparse; caustica does not read sparse accessors ({_FIX} without them)",
                             MeshError)
        width, dtype = COMPONENTS[kind], np.dtype(COMPONENT_TYPES[component])
        element = width * dtype.itemsize
        if "bufferView" not in acc:  # all zeros by the spec: no geometry
            raise self.error(f"{here} has no bufferView (all zeros); {_FIX} with its data", MeshError)
        data, stride = self.buffer_view(acc["bufferView"], f"{here}.bufferView")
        offset = acc.get("byteOffset", 0)
        stride = stride or element
        if not _is_index(offset) or stride < element:
            raise self.error(f"{here}: byteOffset {short(offset)} or the bufferView's byteStride {stride} "
                             f"(elements of {element} bytes) is invalid; {_FIX}", MeshError)
        end = offset + stride * (count - 1) + element
        if end > len(data):
            raise self.error(f"{here} needs {end:,} bytes of its bufferView, which holds {len(data):,}; {_FIX}",
                             MeshError)
        if stride == element:
            raw = np.frombuffer(data, dtype=dtype, count=count * width, offset=offset).reshape(count, width)
        else:
            raw = np.ndarray((count, width), dtype=dtype, buffer=data, offset=offset, strides=(stride, dtype.itemsize))
        if component == 5126:
            return raw.astype(np.float32)  # a copy: the file's bytes are not kept alive
        if acc.get("normalized", False) is True:
            scale = float(np.iinfo(dtype).max)
            return np.maximum(raw.astype(np.float32) / scale, -1.0)
        return raw.copy()

    # Images -----------------------------------------------------------------------

    def image(self, index, where: str, srgb: bool = True) -> np.ndarray:
        """Image ``index`` (PNG or JPEG, from a URI or a bufferView) as a texture: (H, W, 3) float32 linear
        RGB decoded from sRGB (``srgb`` False: the codes scaled to [0, 1], for data textures), its size
        checked from the header before decoding (scene/textures.py)."""
        entry = self.item("images", index, where)
        here = f"images[{index}]"
        if "uri" in entry:
            data = self.resource(entry["uri"], here)
        elif "bufferView" in entry:
            data = bytes(self.buffer_view(entry["bufferView"], f"{here}.bufferView")[0])
        else:
            raise self.error(f"{here} has neither a uri nor a bufferView; {_FIX}")
        from ..textures import decode_texture

        uri = entry.get("uri")
        label = f"{self.path.name}: {here}" + (f" ({short(uri, 40)})" if isinstance(uri, str)
                                                  and not uri.startswith("data:") else "")
        return decode_texture(data, label, f"{here} texture", srgb)


def _json_finite(value) -> bool:
    """Whether a JSON value is a finite number (bools are not): a fast rules.finite for parsed JSON,
    whose numbers are Python ints and floats (an int beyond float range is not finite)."""
    kind = type(value)
    return (kind is float and math.isfinite(value)) or (kind is int and -_FLOAT_MAX <= value <= _FLOAT_MAX)


def _is_index(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


# Opening ------------------------------------------------------------------------


def open_gltf(path: Path) -> GltfFile:
    """The document of a ``.glb`` or ``.gltf`` file; SceneError for a truncated or malformed container."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SceneError(f"cannot read {path}: {exc.strerror or first_line(exc)}; check its permissions") from None
    binary = None
    if data[:4] == GLB_MAGIC:
        text, binary = _glb_chunks(path, data)
    elif path.suffix.lower() == ".glb":
        raise SceneError(f"{path.name} is not a binary glTF (it does not start with 'glTF'); "
                         "re-export it as .glb or rename it")
    else:
        text = data
    try:
        doc = json.loads(bytes(text).decode("utf-8"))
    except UnicodeDecodeError:
        raise SceneError(f"{path.name}: the glTF JSON is not UTF-8 text; re-export the file") from None
    except json.JSONDecodeError as exc:
        raise SceneError(f"{path.name}: the glTF JSON is malformed ({exc.msg} at line {exc.lineno}); "
                         "re-export the file") from None
    except RecursionError:  # the JSON parser recurses once per level of nested arrays and objects
        raise SceneError(f"{path.name}: the glTF JSON nests arrays or objects too deeply to parse; re-export the "
                         "file (glTF needs a few levels)") from None
    if not isinstance(doc, dict):
        raise SceneError(f"{path.name}: the glTF JSON must be an object; re-export the file")
    version = doc.get("asset", {}).get("version") if isinstance(doc.get("asset"), dict) else None
    if not isinstance(version, str) or not version.startswith("2."):
        raise SceneError(f"{path.name} is glTF version {short(version)}; caustica reads glTF 2.0 "
                         "(re-export it as glTF 2.0)")
    return GltfFile(path, doc, binary)


def _glb_chunks(path: Path, data: bytes) -> tuple[memoryview, memoryview | None]:
    """The JSON and (optional) BIN chunks of a GLB file, every length checked against the file."""
    name = path.name
    if len(data) < 20:
        raise SceneError(f"{name} is truncated: {len(data)} bytes, shorter than a GLB header; re-export it")
    version, total = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise SceneError(f"{name} is GLB version {version}; caustica reads glTF 2.0 (re-export it)")
    if total > len(data):
        raise SceneError(f"{name} is truncated: its header says {total:,} bytes, the file has {len(data):,}; "
                         "download or export it again")
    view = memoryview(data)[:total]
    chunks, position = [], 12
    while position < total:
        if position + 8 > total:
            raise SceneError(f"{name} is truncated inside a chunk header at byte {position:,}; re-export it")
        length, kind = struct.unpack_from("<II", view, position)
        if position + 8 + length > total:
            raise SceneError(f"{name} is truncated: a chunk of {length:,} bytes at byte {position:,} runs past "
                             f"the end ({total:,} bytes); download or export it again")
        chunks.append((kind, view[position + 8:position + 8 + length]))
        position += 8 + length
    if not chunks or chunks[0][0] != GLB_JSON:
        raise SceneError(f"{name}: the first GLB chunk must be JSON; re-export the file")
    binary = chunks[1][1] if len(chunks) > 1 and chunks[1][0] == GLB_BIN else None
    return chunks[0][1], binary
