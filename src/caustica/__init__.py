"""caustica: real-time reflections, refractions and caustics on the GPU, measured against exact paths."""
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

__version__ = "0.1.0"


def load_scene(path_or_preset, camera: str | None = None):
    """Load a TOML scene file, a glTF 2.0 file (.glb, .gltf) or a built-in preset by name; ``camera``
    picks a glTF camera by name."""
    from .scene.io import load_scene as _load

    return _load(path_or_preset, camera)


def __getattr__(name):
    if name == "Renderer":
        from .renderer import Renderer

        return Renderer
    if name == "plan":
        from .techniques.auto import plan

        return plan
    if name == "batch":  # the package caustica.batch, callable as the function batch()
        import importlib

        return importlib.import_module(".batch", __name__)
    if name == "show":
        from .notebook import show

        return show
    raise AttributeError(name)


__all__ = ["load_scene", "Renderer", "plan", "show", "batch", "CausticaError", "EnvironmentImageError", "GLUnavailableError",
           "MeshError", "MissingExtraError", "OutputError", "RendererClosedError", "RenderOptionError", "SceneError",
           "TechniqueError"]
