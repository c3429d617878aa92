"""Interactive viewer: ``caustica view SCENE`` (glfw + Dear ImGui over the renderer's own passes).

Needs the ``viewer`` extra (glfw, imgui-bundle, PyOpenGL) and a display.
"""
from .app import CloseReport, Viewer, ViewerError, check_display
from .orbit import OrbitCamera

__all__ = ["CloseReport", "OrbitCamera", "Viewer", "ViewerError", "check_display"]
