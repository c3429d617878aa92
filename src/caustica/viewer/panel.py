"""The ImGui panel (technique, parameters, materials, lights, camera, inspector, side by side) and the overlay.

Parameter widgets come from :func:`caustica.viewer.params.param_specs`, so a
new technique's parameters appear with no change here.
"""
from __future__ import annotations

import functools
import statistics

import numpy as np

from ..images import TONEMAPS
from ..techniques import get_technique, technique_names
from .display import MODES
from .frames import channel_textures
from .params import MATERIAL_FIELDS, param_specs
from .state import VIEW_ANTIALIAS_MODES, render_status, technique_label

SPP_CHOICES = (1, 4, 9, 16)
PANEL_WIDTH = 360  # pixels at the window's right edge while the panel is open
# The label column, measured without ImGui as ImGui lays the panel out with its default font and style:
# ProggyClean 13 px is monospaced, 7 px a glyph (imgui.calc_text_size says the same; tests check it).
GLYPH_WIDTH = 7.0
LABEL_SPACING = 4.0  # style.item_inner_spacing.x: between a widget and its label
WINDOW_PADDING, SCROLLBAR, INDENT = 8.0, 14.0, 21.0  # style.window_padding.x, scrollbar_size, indent_spacing
MIN_WIDGET_WIDTH = 110.0  # the narrowest a widget gets, at one tree level under a scrollbar
# Labels of the panel's own widgets whose label sits right of the item width (the parameters' come from them).
FIXED_LABELS = ("technique", "spp", "antialias", "exposure", "tonemap", "time", "fov y", "distance", "channel",
                "view as", "range", "second", "gain", "file")
OWN_EDITORS = ("techniques", "technique_params")  # per-object's parameters: edited per object and per technique


@functools.lru_cache(maxsize=1)
def technique_choices() -> tuple[str, ...]:
    """Every technique, plus each view technique combined with each caustic technique (built once)."""
    from ..techniques.composite import CausticTechnique
    from ..techniques.raster import RasterTechnique

    names = technique_names()
    caustic = [n for n in names if isinstance(get_technique(n), CausticTechnique)]
    views = [n for n in names if n not in caustic and n != "plain" and isinstance(get_technique(n), RasterTechnique)]
    return (*names, *(f"{v}+{c}" for v in views for c in caustic))


def _combo(imgui, label: str, value, choices) -> tuple[bool, object]:
    choices = list(choices)
    index = choices.index(value) if value in choices else 0
    changed, index = imgui.combo(label, index, [str(c) for c in choices])
    return changed, choices[index]


def field_label(name: str) -> str:
    """A parameter's or material field's label: its name with spaces (``shadow_map_size`` -> ``shadow map size``)."""
    return name.replace("_", " ")


def light_label(light, index: int) -> str:
    """The label of a light's position (or direction) widget."""
    return f"{light.kind} {index} {'position' if hasattr(light, 'position') else 'direction'}"


def technique_labels(technique: str) -> list[str]:
    """The labels of ``technique``'s parameter widgets (what the panel shows for it)."""
    return [field_label(spec.name) for spec in param_specs(get_technique(technique)) if spec.name not in OWN_EDITORS]


def panel_labels(state) -> list[str]:
    """Every label the panel may show for ``state`` (a ViewerState) beside an item-wide widget: its own, the
    parameters of the technique, the second one and per-object's techniques in use, materials, lights."""
    labels = [*FIXED_LABELS, *technique_labels(state.technique)]
    if state.second:
        labels += technique_labels(state.second)
    if state.technique.split("+")[0] == "per-object":
        for technique in {state.object_technique(o.name) for o in state.scene.objects_of("glass")}:
            labels += technique_labels(technique)
    labels += [field_label(field[0]) for obj in state.scene.objects
               for field in MATERIAL_FIELDS.get(obj.material.kind, ())]
    return labels + [light_label(light, i) for i, light in enumerate(state.scene.lights)]


def text_width(text: str) -> float:
    """Width in pixels of ``text`` in ImGui's default font (monospaced)."""
    return GLYPH_WIDTH * len(text)


def label_column(labels, measure=text_width, spacing: float = LABEL_SPACING) -> float:
    """Pixels kept right of the widgets for their labels: the longest label (what ImGui shows: the text before
    any ``##``) and the gap before it."""
    return max((measure(label.split("##")[0]) for label in labels), default=0.0) + spacing


def widget_width(labels, depth: int = 1) -> float:
    """The widgets' width in the panel when the label column fits ``labels``, at tree ``depth`` under a scrollbar."""
    return PANEL_WIDTH - 2 * WINDOW_PADDING - SCROLLBAR - depth * INDENT - label_column(labels)


def param_widget(imgui, spec, value):
    """One widget for one parameter; returns (changed, new value)."""
    label = field_label(spec.name)
    if spec.kind == "bool":
        return imgui.checkbox(label, bool(value))
    if spec.kind == "choice":
        return _combo(imgui, label, value, spec.choices)
    if spec.kind == "int":
        low, high = int(spec.low if spec.low is not None else -2**30), int(spec.high if spec.high is not None else 2**30)
        changed, new = imgui.drag_int(label, int(value), spec.speed, low, high)
        return changed, spec.clamp(new)
    if spec.kind == "float":
        low = float(spec.low) if spec.low is not None else -1e9
        high = float(spec.high) if spec.high is not None else 1e9
        changed, new = imgui.drag_float(label, float(value), spec.speed, low, high, "%.4g")
        return changed, spec.clamp(new)
    imgui.text(f"{label}: {value!r}")
    return False, value


def _parameters(viewer, imgui, technique: str, params: dict, second: bool) -> None:
    for spec in param_specs(get_technique(technique)):
        if spec.name in OWN_EDITORS:
            continue
        value = params.get(spec.name, spec.default)
        changed, new = param_widget(imgui, spec, value)
        if changed:
            viewer.set_param(spec.name, new, second=second)
    if technique.split("+")[0] == "per-object" and not second:
        _per_object_parameters(viewer, imgui, params)


def _per_object_parameters(viewer, imgui, params: dict) -> None:
    """per-object: the parameters of each view technique in use, set as ``technique.name``."""
    in_use = sorted({viewer.object_technique(o.name) for o in viewer.scene.objects_of("glass")})
    stored = params.get("technique_params", {})
    for technique in in_use:
        if not imgui.tree_node(f"{technique} parameters##per-object"):
            continue
        for spec in param_specs(get_technique(technique)):
            if spec.name == "shadow_map_size":  # shared, set above
                continue
            key = f"{technique}.{spec.name}"
            value = params.get(key, stored.get(technique, {}).get(spec.name, spec.default))
            changed, new = param_widget(imgui, spec, value)
            if changed:
                viewer.set_param(key, new)
        imgui.tree_pop()


def draw_panel(viewer) -> None:
    """The panel window along the right edge."""
    imgui = viewer.imgui
    width, height = viewer.glfw.get_framebuffer_size(viewer.window)
    imgui.set_next_window_pos((width - PANEL_WIDTH, 0))
    imgui.set_next_window_size((PANEL_WIDTH, height))
    imgui.set_next_window_bg_alpha(1.0)  # opaque: the window under it is not cleared each frame
    flags = imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_resize | imgui.WindowFlags_.no_collapse
    imgui.begin("caustica", None, flags)
    # Widgets end where the longest label starts (negative: from the right edge, at any tree depth).
    column = label_column(panel_labels(viewer.state), lambda text: imgui.calc_text_size(text).x,
                          imgui.get_style().item_inner_spacing.x)
    imgui.push_item_width(-column)
    imgui.text(f"{viewer.scene.name}  ({viewer.device.info['renderer'][:28]})")
    if viewer.error:
        imgui.text_colored((1.0, 0.45, 0.35, 1.0), viewer.error[:200])
    # Technique and its parameters.
    changed, name = _combo(imgui, "technique", viewer.technique, technique_choices())
    if changed:
        viewer.set_technique(name)
    changed, spp = _combo(imgui, "spp", viewer.spp, SPP_CHOICES)
    if changed:
        viewer.spp = spp
        viewer.changed()
    changed, antialias = _combo(imgui, "antialias", viewer.antialias, VIEW_ANTIALIAS_MODES)
    if changed:
        viewer.set_antialias(antialias)
    changed, viewer.exposure = imgui.drag_float("exposure", viewer.exposure, 0.05, -10.0, 10.0, "%.2f")
    changed, tonemap = _combo(imgui, "tonemap", viewer.tonemap, TONEMAPS)
    if changed:
        viewer.tonemap = tonemap
    if imgui.collapsing_header("parameters", imgui.TreeNodeFlags_.default_open):
        _parameters(viewer, imgui, viewer.technique, viewer.params, second=False)
    if imgui.collapsing_header("materials", imgui.TreeNodeFlags_.default_open):
        _materials(viewer, imgui)
    if viewer.scene.lights and imgui.collapsing_header("lights"):
        _lights(viewer, imgui)
    if imgui.collapsing_header("camera"):
        _camera(viewer, imgui)
    if viewer.scene_at is not None and imgui.collapsing_header("animation", imgui.TreeNodeFlags_.default_open):
        changed, playing = imgui.checkbox("play (P)", viewer.playing)
        if changed:
            viewer.play(playing)
        changed, value = imgui.drag_float("time", viewer.time, 0.01, 0.0, 1e6, "%.2f s")
        if changed:
            viewer.set_time(value)
    if imgui.collapsing_header("pass inspector", imgui.TreeNodeFlags_.default_open):
        _inspector(viewer, imgui)
    if imgui.collapsing_header("side by side"):
        _side_by_side(viewer, imgui)
    if imgui.collapsing_header("screenshot"):
        _screenshot(viewer, imgui)
    changed, viewer.show_overlay = imgui.checkbox("frame-time overlay (O)", viewer.show_overlay)
    changed, profile = imgui.checkbox("per-pass ms (syncs each pass)", viewer.profile)
    if changed:
        viewer.profile = profile
    imgui.text_disabled("drag: orbit  right drag: pan  wheel: zoom")
    imgui.text_disabled("shift drag / arrows, PgUp/PgDn: move light")
    imgui.text_disabled("F frame  R reset  I inspect  S shot  Tab panel")
    imgui.pop_item_width()
    imgui.end()


def _materials(viewer, imgui) -> None:
    for index, obj in enumerate(viewer.scene.objects):
        fields = MATERIAL_FIELDS.get(obj.material.kind, ())
        if not fields or not imgui.tree_node(f"{obj.name} ({obj.material.kind})##{index}"):
            continue
        if obj.material.kind == "glass":
            _object_technique(viewer, imgui, obj, index)
        for name, kind, low, high in fields:
            value = getattr(obj.material, name)
            if kind == "color":
                changed, new = imgui.color_edit3(f"{field_label(name)}##{index}", [float(v) for v in value])
            else:
                changed, new = imgui.drag_float(f"{field_label(name)}##{index}", float(value), 0.005, low, high, "%.3f")
            if changed:
                viewer.set_material(index, name, np.clip(np.asarray(new, dtype=float), low, high)
                                    if kind == "color" else float(np.clip(new, low, high)))
        imgui.tree_pop()


def _object_technique(viewer, imgui, obj, index: int) -> None:
    """The view technique of one glass object: choosing one switches the viewer to ``per-object``."""
    from ..techniques.per_object import VIEW_TECHNIQUES

    changed, technique = _combo(imgui, f"technique##object{index}", viewer.object_technique(index), VIEW_TECHNIQUES)
    if changed:
        viewer.set_object_technique(index, technique)


def _lights(viewer, imgui) -> None:
    for index, light in enumerate(viewer.scene.lights):
        if hasattr(light, "position"):
            changed, new = imgui.drag_float3(light_label(light, index), [float(v) for v in light.position], 0.02)
            if changed:
                viewer.move_light(index, position=new)
        elif hasattr(light, "direction"):
            changed, new = imgui.drag_float3(light_label(light, index), [float(v) for v in light.direction], 0.01)
            if changed and np.linalg.norm(new) > 1e-6:
                viewer.move_light(index, position=new)


def _camera(viewer, imgui) -> None:
    orbit = viewer.orbit
    if imgui.button("frame (F)"):
        viewer.frame_scene()
    imgui.same_line()
    if imgui.button("reset (R)"):
        viewer.reset_camera()
    changed, orbit.fov_y = imgui.drag_float("fov y", orbit.fov_y, 0.2, 5.0, 150.0, "%.1f deg")
    changed2, orbit.distance = imgui.drag_float("distance", orbit.distance, 0.02, 0.01, 1e4, "%.3f")
    if changed or changed2:
        viewer.changed()
    imgui.text(f"yaw {orbit.yaw:.1f}  pitch {orbit.pitch:.1f}")


def _inspector(viewer, imgui) -> None:
    names = [None, *channel_textures(viewer.main.channels)]
    labels = ["(final image)", *names[1:]]
    index = names.index(viewer.inspect) if viewer.inspect in names else 0
    changed, index = imgui.combo("channel", index, labels)
    if changed:
        viewer.set_inspect(names[index], viewer.inspect_mode)
    if viewer.inspect is None:
        return
    changed, mode = _combo(imgui, "view as", viewer.inspect_mode, ("auto", *MODES[:3]))
    if changed:
        viewer.set_inspect(viewer.inspect, mode)
    texture = channel_textures(viewer.main.channels).get(viewer.inspect)
    if texture is not None:
        imgui.text(f"{texture.size[0]}x{texture.size[1]}, {texture.components} x {texture.dtype}")
    changed, viewer.inspect_auto = imgui.checkbox("auto range", viewer.inspect_auto)
    low, high = viewer.inspect_range
    changed, values = imgui.drag_float2("range", [low, high], 0.01 * max(abs(high - low), 1e-3))
    if changed:
        viewer.inspect_range, viewer.inspect_auto = tuple(values), False


def _side_by_side(viewer, imgui) -> None:
    choices = [None, *technique_choices()]
    labels = ["(off)", *[technique_label(c) for c in choices[1:]]]
    index = choices.index(viewer.second) if viewer.second in choices else 0
    changed, index = imgui.combo("second", index, labels)
    if changed:
        viewer.set_side_by_side(choices[index], viewer.difference)
    if viewer.second:
        changed, difference = imgui.checkbox("difference |a - b|", viewer.difference)
        if changed:
            viewer.set_side_by_side(viewer.second, difference)
        changed, viewer.difference_gain = imgui.drag_float("gain", viewer.difference_gain, 0.1, 0.1, 1000.0, "%.1f")
        if render_status(viewer.other):
            imgui.text(render_status(viewer.other))
        if imgui.tree_node("second's parameters"):
            _parameters(viewer, imgui, viewer.second, viewer.second_params, second=True)
            imgui.tree_pop()


def _screenshot(viewer, imgui) -> None:
    _, viewer.screenshot_path = imgui.input_text("file", getattr(viewer, "screenshot_path", "view.png"))
    if imgui.button("save image (.png/.exr)"):
        try:
            viewer.screenshot(viewer.screenshot_path)
        except Exception as exc:  # shown in the panel, the window stays open
            viewer.error = f"screenshot: {exc}"
    imgui.same_line()
    if imgui.button("save window"):
        viewer._grab_path = viewer.screenshot_path


def _window_rect(imgui, window_height: int) -> tuple[int, int, int, int]:
    """The current ImGui window as (x, y, w, h) from the window's lower left (GL convention)."""
    (x, y), (w, h) = imgui.get_window_pos(), imgui.get_window_size()
    return int(x), int(window_height - y - h), int(w) + 1, int(h) + 1


OVERLAY_FLAGS = ("no_decoration", "always_auto_resize", "no_inputs", "no_saved_settings", "no_focus_on_appearing",
                 "no_nav")  # the overlay's and the captions' ImGui windows: text only, no input


def _text_window_flags(imgui) -> int:
    return functools.reduce(lambda a, b: a | b, (getattr(imgui.WindowFlags_, name) for name in OVERLAY_FLAGS))


def draw_captions(viewer, rects) -> list:
    """Each view's caption (ViewerState.view_captions) at its lower left; returns where they were drawn
    (x, y, w, h from the window's lower left) for the UI layer to blend."""
    imgui = viewer.imgui
    height = viewer.glfw.get_window_size(viewer.window)[1]
    drawn = []
    for index, (text, (x, y, w, _)) in enumerate(zip(viewer.state.view_captions(viewer.main, viewer.other), rects)):
        if not text:
            continue
        imgui.set_next_window_pos((x + 8, height - y - 8), 0, (0.0, 1.0))
        imgui.set_next_window_bg_alpha(0.55)
        imgui.begin(f"caption {index}", None, _text_window_flags(imgui))
        imgui.push_text_wrap_pos(max(GLYPH_WIDTH, w - 16 - 2 * WINDOW_PADDING))  # the box stays in its view
        imgui.text(text)
        imgui.pop_text_wrap_pos()
        drawn.append(_window_rect(imgui, height))
        imgui.end()
    return drawn


def draw_overlay(viewer) -> None:
    """Frame time (ms, fps), the technique's render ms and, when profiling, per-pass ms, top left of the view."""
    imgui = viewer.imgui
    imgui.set_next_window_pos((8, 8))
    imgui.set_next_window_bg_alpha(0.55)
    imgui.begin("overlay", None, _text_window_flags(imgui))
    viewer.overlay_rect = _window_rect(imgui, viewer.glfw.get_window_size(viewer.window)[1])
    frame = statistics.median(viewer.frame_ms) if viewer.frame_ms else 0.0
    imgui.text(f"{viewer.technique}: {frame:.1f} ms/frame, {1000.0 / frame if frame else 0.0:.1f} fps")
    imgui.text(f"{'passes' if viewer.profile else 'pass submission'} {viewer.main.render_ms:.1f} ms, {viewer.main.color.size[0] if viewer.main.color else 0}"
               f"x{viewer.main.color.size[1] if viewer.main.color else 0}")
    for name, ms in viewer.main.pass_ms.items():
        imgui.text(f"  {name}: {ms:.2f} ms")
    if viewer.inspect:
        imgui.text(f"inspecting {viewer.inspect}")
    imgui.end()
