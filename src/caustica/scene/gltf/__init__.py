"""glTF 2.0 scenes in and out (docs/gltf.md has the field-by-field mapping).

- :mod:`.container`: the untrusted-file layer (GLB chunks, URIs, buffers, accessors, images);
- :mod:`.read`: document to objects, lights and cameras; :mod:`.write`: a Scene to ``.glb``/``.gltf``;
- :mod:`.matrices`: node transforms; :mod:`.units`: photometric light units at 683 lm/W.
"""
from __future__ import annotations

from pathlib import Path

GLTF_SUFFIXES = (".glb", ".gltf")


def load_gltf(path: str | Path, camera: str | None = None):
    """A Scene from a ``.glb``/``.gltf`` file: its objects and lights, the camera called ``camera`` (else
    the first; without any, one framing the scene) and caustica's default environment."""
    from ..scene import Scene
    from .read import choose_camera, read_gltf

    imported = read_gltf(path)
    scene = Scene(objects=imported.objects, lights=imported.lights, name=imported.name)
    scene.camera = choose_camera([imported], camera, scene.bounds())
    return scene


def write_gltf(scene, path: str | Path) -> Path:
    """Write ``scene`` as glTF 2.0 (``.glb`` binary, or ``.gltf`` with embedded data), atomically."""
    from .write import write_gltf as write

    return write(scene, path)
