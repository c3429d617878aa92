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
    the first; without any, one framing the scene) and the environment caustica's export kept in
    ``extras.caustica`` (else caustica's default one). ``scene.gltf`` records what export writes back."""
    from ..scene import Scene
    from .read import choose_camera, read_gltf

    path = Path(path)
    imported = read_gltf(path)
    scene = Scene(objects=imported.objects, lights=imported.lights, name=imported.name, gltf=imported.origin)
    if imported.environment is not None:
        scene.environment = kept_environment(imported.environment, path)
    scene.camera = choose_camera([imported], camera, scene.bounds())
    return scene


def kept_environment(table: dict, path: Path):
    """The environment of caustica's ``extras.caustica.environment`` in a glTF document: a TOML
    [environment] table, its file inside the glTF's folder."""
    from ...errors import SceneError
    from ..io import _environment

    file = table.get("file")
    folder = path.parent.resolve()
    if isinstance(file, str) and not _inside(folder, file):
        raise SceneError(f"{path.name}: extras.caustica.environment.file {file!r} leaves the glTF's folder; copy "
                         "the image beside the glTF and name it by a relative path")
    try:
        return _environment(table, path.parent)
    except SceneError as exc:
        raise type(exc)(f"{path.name}: in extras.caustica: {exc}") from None


def _inside(folder: Path, relative: str) -> bool:
    """Whether ``relative`` names a path inside ``folder`` (False for one that cannot be resolved)."""
    try:
        return (folder / relative).resolve().is_relative_to(folder)
    except (OSError, ValueError, RuntimeError):
        return False


def write_gltf(scene, path: str | Path) -> Path:
    """Write ``scene`` as glTF 2.0 (``.glb`` binary, or ``.gltf`` with embedded data), atomically."""
    from .write import write_gltf as write

    return write(scene, path)
