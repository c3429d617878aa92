"""caustica: real-time reflections, refractions and caustics on the GPU, measured against exact paths.

``import caustica`` stays light: the renderer, the scene types and the other names below are imported
on first use.
"""
from .errors import (
    CausticaError,
    EnvironmentImageError,
    GLUnavailableError,
    MeshError,
    MissingExtraError,
    OutputError,
    RendererClosedError,
    RenderOptionError,
    SceneError,
    TechniqueError,
)

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing, pathlib or __future__ at start-up
if TYPE_CHECKING:
    from pathlib import Path

    from .scene.scene import Scene

__version__ = "0.1.0"


def load_scene(path_or_preset: "str | Path", camera: "str | None" = None) -> "Scene":
    """Load a TOML scene file, a glTF 2.0 file (.glb, .gltf) or a built-in preset by name; ``camera``
    picks a glTF camera by name."""
    from .scene.io import load_scene as _load

    return _load(path_or_preset, camera)


def scene_from_dict(data: "dict[str, object]", base_dir: "str | Path" = ".", name: str = "scene") -> "Scene":
    """A Scene from a dict in the TOML scene files' format (docs/scenes.md), e.g.
    ``{"camera": {"position": [0, 1, 4]}, "objects": [{"shape": "sphere", "material": "glass"}]}``;
    file names in it resolve against ``base_dir``, ``name`` is the default for its ``name`` key."""
    if not isinstance(data, dict):
        raise SceneError(f"a scene dict must be a dict of the scene file's tables, not a {type(data).__name__}; "
                         "see docs/scenes.md")
    from .scene.io import parse_scene

    return parse_scene(data, base_dir=base_dir, default_name=name)


# Public names imported on first use: name -> the module that defines it.
_LAZY = {
    "Renderer": ".renderer",
    "plan": ".planning.rules",
    "show": ".notebook",
    "export_scene": ".scene.io",
    "Camera": ".scene.camera",
    "Scene": ".scene.scene",
    "SceneObject": ".scene.scene",
    "Transform": ".scene.transform",
    "Mesh": ".scene.mesh",
    "load_mesh": ".scene.mesh_files",
    "Glass": ".scene.materials",
    "Diffuse": ".scene.materials",
    "Mirror": ".scene.materials",
    "Principled": ".scene.materials",
    "water": ".scene.materials",
    "PointLight": ".scene.lights",
    "DirectionalLight": ".scene.lights",
    "SpotLight": ".scene.lights",
    "LineLight": ".scene.lights",
    "Environment": ".scene.environment",
    "load_environment": ".scene.environment",
    "procedural_environment": ".scene.environment",
}


def __getattr__(name: str) -> object:
    from importlib import import_module  # here, not at the top: importlib costs import caustica half a millisecond

    if name == "batch":  # the package caustica.batch, callable as the function batch()
        return import_module(".batch", __name__)
    if name not in _LAZY:
        raise AttributeError(f"module 'caustica' has no attribute {name!r}")
    value = getattr(import_module(_LAZY[name], __name__), name)
    globals()[name] = value  # later lookups skip __getattr__
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = ["load_scene", "scene_from_dict", "batch", *_LAZY, "CausticaError", "EnvironmentImageError",
           "GLUnavailableError", "MeshError", "MissingExtraError", "OutputError", "RendererClosedError",
           "RenderOptionError", "SceneError", "TechniqueError"]
