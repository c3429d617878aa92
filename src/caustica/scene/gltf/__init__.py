"""glTF 2.0 scenes in and out (docs/gltf.md has the field-by-field mapping); scene/io.py turns a read
document into a Scene, as it does a TOML file.

- :mod:`.container`: the untrusted-file layer (GLB chunks, URIs, buffers, accessors, images);
- :mod:`.read`: document to objects, lights and cameras; :mod:`.write`: a Scene to ``.glb``/``.gltf``;
- :mod:`.matrices`: node transforms; :mod:`.units`: photometric light units at 683 lm/W.
"""
from __future__ import annotations

from pathlib import Path

GLTF_SUFFIXES = (".glb", ".gltf")


def write_gltf(scene, path: str | Path) -> Path:
    """Write ``scene`` as glTF 2.0 (``.glb`` binary, or ``.gltf`` with embedded data), atomically."""
    from .write import write_gltf as write

    return write(scene, path)
