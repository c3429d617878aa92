"""``caustica.show(scene)`` for Jupyter: an inline image, with widgets where ipywidgets is installed.

Renders headless (no window, no display needed), its long steps' progress shown as plain lines under the
cell. Without ipywidgets, or with ``widgets=False``, the result is a PIL image, which Jupyter shows inline.
With widgets: technique, orbit (yaw, pitch, zoom), exposure and every
parameter of the technique, each change re-rendering the image.

Outside a notebook (plain Python, a script) nothing could show widgets: ``show`` says so up front on
stderr and returns the PIL image (``.show()`` opens it in an image viewer, ``.save("x.png")`` writes it;
``caustica.Renderer`` gives the float image).
"""
from __future__ import annotations

import dataclasses
import io

import numpy as np


def to_pil(image: np.ndarray, exposure: float = 0.0, tonemap: str = "clip"):
    """A linear float image as an 8-bit sRGB PIL image, exactly as ``write_image`` encodes PNGs
    (``tonemap``: "clip" or "filmic")."""
    from PIL import Image

    from .images import to_srgb8

    return Image.fromarray(to_srgb8(image, exposure, tonemap))


def show(scene, technique: str = "auto", size=None, spp: int = 1, exposure: float = 0.0, widgets: bool | None = None,
         **params):
    """Render ``scene`` (a Scene, preset name or .toml path) and return something Jupyter displays.

    ``widgets``: None uses ipywidgets when installed and in a notebook, True requires it, False returns a
    static PIL image. Outside a notebook (and ``widgets`` not True) a note says so before the render and the
    PIL image comes back.
    """
    from . import load_scene
    from .errors import MissingExtraError
    from .renderer import Renderer

    if isinstance(scene, str):
        scene = load_scene(scene)
    renderer = Renderer(size, progress=True)  # a notebook's stderr is no terminal: plain lines under the cell
    if widgets is None and not in_notebook():
        from .progress import note

        width, height = renderer.camera_for(scene).size
        note(f"show: not in a notebook, so no inline image or widgets: rendering {scene.name or 'the scene'} "
             f"({width}x{height}, {technique}) and returning a PIL image (.show() opens it, .save('x.png') writes it)")
        widgets = False
    if widgets is not False:
        try:
            import ipywidgets  # noqa: F401
        except ImportError:
            if widgets:
                raise MissingExtraError("show(widgets=True) needs ipywidgets; pip install 'caustica[notebook]' "
                                        "or pass widgets=False") from None
            widgets = False
        else:
            widgets = True  # None meant "when installed" (it fell through to the static image before)
    if not widgets:
        return to_pil(renderer.render(scene, technique, spp, **params), exposure)
    return _widget(scene, renderer, technique, spp, exposure, params)


def in_notebook() -> bool:
    """Whether this runs in a Jupyter kernel (IPython's ZMQ shell), where a returned image or widget shows."""
    import sys

    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None and hasattr(ipython, "get_ipython") else None
    return shell is not None and type(shell).__name__ == "ZMQInteractiveShell"


def _widget(scene, renderer, technique, spp, exposure, params):
    import ipywidgets as w

    from .techniques import get_technique, technique_names
    from .viewer.orbit import OrbitCamera
    from .viewer.params import param_specs

    orbit = OrbitCamera(scene.camera)
    state = {"technique": technique, "params": dict(params)}
    image = w.Image(format="png")
    status = w.Label()
    names = [n for n in technique_names() if get_technique(n).uses_gl] or technique_names()
    technique_box = w.Dropdown(options=sorted(set(names) | {technique}), value=technique, description="technique")
    yaw = w.FloatSlider(value=0.0, min=-180.0, max=180.0, step=1.0, description="yaw")
    pitch = w.FloatSlider(value=0.0, min=-80.0, max=80.0, step=1.0, description="pitch")
    zoom = w.FloatSlider(value=0.0, min=-10.0, max=10.0, step=0.5, description="zoom")
    exposure_box = w.FloatSlider(value=float(exposure), min=-6.0, max=6.0, step=0.1, description="exposure")
    param_box = w.VBox()
    home_yaw, home_pitch, home_distance = orbit.yaw, orbit.pitch, orbit.distance

    def redraw(*_):
        orbit.yaw, orbit.pitch = home_yaw + yaw.value, float(np.clip(home_pitch + pitch.value, -89.0, 89.0))
        orbit.distance = home_distance * 0.9 ** zoom.value
        size = renderer.camera_for(scene).size
        view = dataclasses.replace(scene, camera=orbit.camera(size))
        try:
            picture, ms = renderer.render_timed(view, state["technique"], spp, **state["params"])
        except Exception as exc:  # shown under the image; the widget stays usable
            status.value = f"caustica: {exc}"
            return
        buffer = io.BytesIO()
        to_pil(picture, exposure_box.value).save(buffer, format="PNG")
        image.value = buffer.getvalue()
        status.value = f"{state['technique']}: {ms:.1f} ms"

    def controls():
        children = []
        for spec in param_specs(get_technique(state["technique"])):
            value = state["params"].get(spec.name, spec.default)
            if spec.kind == "bool":
                box = w.Checkbox(value=bool(value), description=spec.name)
            elif spec.kind == "choice":
                box = w.Dropdown(options=list(spec.choices), value=value, description=spec.name)
            elif spec.kind in ("int", "float") and spec.low is not None and spec.high is not None:
                slider = w.IntSlider if spec.kind == "int" else w.FloatSlider
                box = slider(value=value, min=spec.low, max=spec.high, description=spec.name)
            elif spec.kind in ("int", "float"):
                box = (w.IntText if spec.kind == "int" else w.FloatText)(value=value, description=spec.name)
            else:
                continue
            box.observe(lambda change, name=spec.name: (state["params"].__setitem__(name, change["new"]), redraw()),
                        names="value")
            children.append(box)
        param_box.children = children

    def switch(change):
        known = {s.name for s in param_specs(get_technique(change["new"]))}
        state["technique"] = change["new"]
        state["params"] = {k: v for k, v in state["params"].items() if k in known}
        controls()
        redraw()

    technique_box.observe(switch, names="value")
    for box in (yaw, pitch, zoom, exposure_box):
        box.observe(redraw, names="value")
    controls()
    redraw()
    return w.HBox([w.VBox([image, status]), w.VBox([technique_box, yaw, pitch, zoom, exposure_box, param_box])])
