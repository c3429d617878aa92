"""The viewer's editing model: what the window draws, with no window, GL context, glfw or ImGui.

:class:`ViewerState` holds the scene being edited, the orbit camera, the
technique and its parameters (and a second one beside it or differenced), the
inspected channel, the animation time and which panels show. Its methods are
the edits the mouse, keys, panel and scripted events make; each counted edit
bumps ``state_version``, which CPU techniques re-render on.
"""
from __future__ import annotations

import dataclasses
import inspect

import numpy as np

from ..errors import CausticaError, RenderOptionError
from ..images import TONEMAPS
from ..passes.post.resolve import ANTIALIAS_MODES, check_antialias
from ..scene import Scene
from ..techniques import get_technique
from ..techniques.base import check_spp
from .display import auto_mode, value_range
from .orbit import OrbitCamera
from .params import param_specs

VIEW_ANTIALIAS_MODES = tuple(mode for mode in ANTIALIAS_MODES if mode != "adaptive")


def check_view_antialias(antialias) -> str:
    """``antialias`` when the viewer draws it (VIEW_ANTIALIAS_MODES); RenderOptionError otherwise."""
    if check_antialias(antialias) not in VIEW_ANTIALIAS_MODES:
        raise RenderOptionError(f"antialias '{antialias}' renders every frame twice and is for still images; the viewer "
                                f"takes {', '.join(VIEW_ANTIALIAS_MODES)} (use 'caustica render --antialias adaptive')")
    return antialias


def animated_variant(scene_name: str):
    """``f(time) -> Scene`` for an animated preset, or None.

    A presets module may list them in ``ANIMATED`` ({name: f}); otherwise a
    function ``<last word>_scene(time)`` (``caustics-pool`` -> ``pool_scene``) counts.
    """
    from ..scene import presets

    table = getattr(presets, "ANIMATED", None)
    if isinstance(table, dict) and scene_name in table:
        return table[scene_name]
    candidate = getattr(presets, scene_name.split("-")[-1].replace("-", "_") + "_scene", None)
    if (callable(candidate) and scene_name in getattr(presets, "PRESETS", {})
            and "time" in inspect.signature(candidate).parameters):
        return candidate
    return None


def technique_label(name: str) -> str:
    """How the viewer names a technique in its lists and captions (``mitsuba`` is the cached reference)."""
    return "mitsuba (cached reference)" if name == "mitsuba" else name


def render_status(image) -> str:
    """What a view's caption says of its frame (a frames.LiveImage, or None): nothing when it is current;
    while a CPU render runs, its progress, what is shown meanwhile, e.g. ``rendering 37%, 1/4 resolution``."""
    if image is None or not image.pending:
        return ""
    status = "rendering" if image.progress is None else f"rendering {image.progress:.0%}"
    if image.color is None:
        return status + ", nothing to show yet"
    return status + (f", 1/{image.preview} resolution" if image.preview > 1 else ", showing the last image")


class ViewerState:
    """The edited scene and view settings; ``viewport()`` gives the first view's (width, height) in pixels
    (the scene camera's size unless a window says otherwise)."""

    def __init__(self, scene: Scene, technique: str = "auto", params: dict | None = None, spp: int = 1,
                 exposure: float = 0.0, panel: bool = True, overlay: bool = True, viewport=None,
                 tonemap: str = "clip", antialias: str = "none"):
        chosen = get_technique(technique)
        chosen.make_params(**(params or {}))  # fail on bad input before opening a window
        check_spp(chosen, int(spp))
        self.antialias = check_view_antialias(antialias)  # as Renderer.render's but adaptive (VIEW_ANTIALIAS_MODES)
        self.tonemap = tonemap  # the PNG tone curve (images.TONEMAPS) of the views and screenshots; checked
        self.scene = scene
        self.orbit = OrbitCamera(scene.camera)
        self.technique, self.params = technique, dict(params or {})
        self.spp, self.exposure = int(spp), float(exposure)
        self.show_panel, self.show_overlay = panel, overlay
        self.second: str | None = None  # side-by-side technique ("mitsuba" is the cached reference)
        self.second_params: dict = {}
        self.difference, self.difference_gain = False, 4.0
        self.inspect: str | None = None  # channel name shown instead of the final image
        self.inspect_mode, self.inspect_range, self.inspect_auto = "auto", (0.0, 1.0), True
        self.scene_at = animated_variant(scene.name)
        self.time, self.playing = 0.0, False
        self.error: str | None = None
        self.state_version = 0  # bumped on every change: CPU techniques re-render on it
        self.viewport = viewport or (lambda: tuple(self.scene.camera.size))

    def changed(self) -> None:
        self.state_version += 1

    @property
    def tonemap(self) -> str:
        """The tone curve after the exposure, as ``caustica render --tonemap``: "clip" or "filmic".

        Display only (like the exposure): setting it re-renders nothing. A bad name raises CausticaError."""
        return self._tonemap

    @tonemap.setter
    def tonemap(self, value: str) -> None:
        if value not in TONEMAPS:
            raise CausticaError(f"unknown tonemap '{value}'; use one of {', '.join(TONEMAPS)}")
        self._tonemap = value

    @property
    def side_by_side(self) -> bool:
        """Two views side by side (a second technique, not differenced)."""
        return bool(self.second) and not self.difference

    def view_captions(self, main=None, other=None) -> list[str]:
        """The text over each view, from its frame (``main``, ``other``: frames.LiveImage or None): side by
        side, each half's technique; differenced, both names and the gain; a lone view only while a CPU render
        runs. Each adds ``render_status`` (a CPU render's progress); '' is no caption."""
        def caption(name, image):
            status = render_status(image)
            return f"{technique_label(name)}: {status}" if status else technique_label(name)

        if self.side_by_side:
            return [caption(self.technique, main), caption(self.second, other)]
        if self.second:  # the difference view
            status = "; ".join(f"{name} {render_status(image)}" for name, image in
                               ((self.technique, main), (self.second, other)) if render_status(image))
            return [f"|{self.technique} - {technique_label(self.second)}| x {self.difference_gain:g}"
                    + (f": {status}" if status else "")]
        return [caption(self.technique, main) if render_status(main) else ""]

    # The camera.
    def camera(self, size=None):
        """The scene camera the first view renders (its current orbit), at ``size`` or the view's size."""
        return self.orbit.camera(self.viewport() if size is None else size)

    def scene_view(self, size=None) -> Scene:
        """The scene as the first view sees it: for headless renders of the same frame."""
        return dataclasses.replace(self.scene, camera=self.camera(size))

    def orbit_by(self, dx: float, dy: float) -> None:
        self.orbit.orbit(dx, dy)
        self.changed()

    def pan_by(self, dx: float, dy: float) -> None:
        self.orbit.pan(dx, dy, self.viewport()[1])
        self.changed()

    def zoom_by(self, steps: float) -> None:
        self.orbit.zoom(steps)
        self.changed()

    def frame_scene(self) -> None:
        width, height = self.viewport()
        self.orbit.frame(self.scene.bounds(), width / max(1, height))
        self.changed()

    def reset_camera(self) -> None:
        self.orbit.reset()
        self.changed()

    # The technique and its parameters.
    def set_technique(self, name: str) -> None:
        """Switch technique, keeping the parameters the new one also has."""
        technique = get_technique(name)
        known = {spec.name for spec in param_specs(technique)}
        # per-object (alone or under caustics) also keeps its techniques' qualified parameters.
        kept = {k: v for k, v in self.params.items()
                if k in known or k.rpartition(".")[0] in technique.qualified_prefixes}
        self.technique, self.params, self.inspect = name, kept, None
        self.error = None
        self.changed()

    def set_param(self, name: str, value, second: bool = False) -> None:
        """Set a technique parameter; a rejected value is reported in ``error`` and not applied."""
        technique = self.second if second else self.technique
        params = dict(self.second_params if second else self.params, **{name: value})
        try:
            get_technique(technique).make_params(**params)
        except CausticaError as exc:
            self.error = str(exc)
            return
        if second:
            self.second_params = params
        else:
            self.params = params
        self.error = None
        self.changed()

    def set_spp(self, value) -> None:
        """Samples per pixel, checked against the technique (a TechniqueError when it does not take them)."""
        check_spp(get_technique(self.technique), int(value))
        self.spp = int(value)
        self.changed()

    def set_antialias(self, value: str) -> None:
        """Anti-aliasing of both views, as ``Renderer.render``'s (a RenderOptionError for an unknown mode or adaptive)."""
        self.antialias = check_view_antialias(value)
        self.changed()

    def cycle_antialias(self) -> None:
        """The next anti-aliasing mode (none, edge, msaa, none...): the A key."""
        modes = VIEW_ANTIALIAS_MODES
        self.set_antialias(modes[(modes.index(self.antialias) + 1) % len(modes)])

    def set_side_by_side(self, technique: str | None, difference: bool = False) -> None:
        """Show ``technique`` beside the main one (None: back to one view); ``difference`` shows |a - b| instead."""
        if technique is not None:
            get_technique(technique)
        self.second, self.second_params, self.difference = technique, {}, bool(difference and technique)
        self.changed()

    # Materials and per-object techniques.
    def set_material(self, obj, field: str, value) -> None:
        """Change a material field (``ior``, ``absorption_color``...) of an object given by index or name."""
        target = self._object(obj)
        try:
            target.material = dataclasses.replace(target.material, **{field: value})
        except (TypeError, ValueError) as exc:
            self.error = f"{target.name}: {exc}"
            return
        self.error = None
        self.changed()

    def object_technique(self, obj) -> str:
        """The view technique that shows glass object ``obj`` (index or name) now."""
        from ..techniques.per_object import VIEW_TECHNIQUES

        view = self.technique.split("+")[0]
        if view == "per-object":
            params = {k: self.params[k] for k in ("techniques", "default") if k in self.params}
            return self._per_object_params(**params).technique_of(self._object(obj))
        return view if view in VIEW_TECHNIQUES else self._per_object_params().default

    def set_object_technique(self, obj, technique: str) -> None:
        """Show glass object ``obj`` (index or name) with view ``technique``: switches to ``per-object``
        (``per-object+<caustics>`` when caustics were on), the other objects keeping what they showed."""
        target = self._object(obj)
        if target.material.kind != "glass":
            self.error = f"{target.name} is {target.material.kind}; only glass objects choose a technique"
            return
        from ..techniques.composite import CausticTechnique

        view, plus, caustics = self.technique.partition("+")
        if not plus and isinstance(get_technique(view), CausticTechnique):  # a caustic technique named alone
            plus, caustics = "+", view
        mapping = {o.name: self.object_technique(o.name) for o in self.scene.objects_of("glass")}
        mapping[target.name] = technique
        default = self.object_technique(target.name) if view != "per-object" else self.params.get(
            "default", self._per_object_params().default)
        try:
            self._per_object_params(techniques=mapping, default=default)
        except CausticaError as exc:
            self.error = str(exc)
            return
        name = "per-object" + plus + caustics
        if name != self.technique:
            self.set_technique(name)
        self.params = {**self.params, "techniques": {k: v for k, v in mapping.items() if v != default},
                       "default": default}
        self.error = None
        self.changed()

    @staticmethod
    def _per_object_params(**values):
        return get_technique("per-object").make_params(**values)

    def _object(self, obj):
        if isinstance(obj, str):
            found = [o for o in self.scene.objects if o.name == obj]
            if not found:
                raise CausticaError(f"no object named '{obj}'; objects: {', '.join(o.name for o in self.scene.objects)}")
            return found[0]
        return self.scene.objects[int(obj)]

    # Lights.
    def move_light(self, index: int, delta=None, position=None) -> None:
        """Move light ``index`` by ``delta`` or to ``position``; a directional light turns its direction instead."""
        light = self.scene.lights[int(index)]
        if hasattr(light, "position"):
            new = np.asarray(position if position is not None else light.position + np.asarray(delta, float), float)
            self.scene.lights[int(index)] = dataclasses.replace(light, position=new)
        else:
            new = np.asarray(position if position is not None else light.direction + np.asarray(delta, float), float)
            self.scene.lights[int(index)] = dataclasses.replace(light, direction=new)
        self.changed()

    def drag_light(self, dx: float, dy: float, index: int = 0) -> None:
        """Move a light in the view plane by a drag of (dx, dy) pixels (shift + left drag)."""
        if not self.scene.lights:
            return
        camera = self.camera()
        forward = camera.look_at - camera.position
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, camera.up)
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        scale = 2.0 * self.orbit.distance * np.tan(np.radians(camera.fov_y) / 2.0) / camera.size[1]
        delta = scale * (dx * right - dy * up)
        light = self.scene.lights[index]
        self.move_light(index, delta if hasattr(light, "position") else 0.2 * delta / max(self.orbit.distance, 1e-6))

    # The pass inspector.
    def set_inspect(self, channel: str | None, mode: str = "auto", channels: dict | None = None) -> None:
        """Show a channel of the main technique by name (``back_surface``, ``shadow_maps[0]``...), None for the
        image; ``channels`` (name -> texture of the last frame, None before one) checks the name."""
        self.inspect, self.inspect_mode, self.inspect_auto = channel, mode, True
        if channel is not None and channels is not None:
            if channel not in channels:
                self.error = f"no channel '{channel}' in {self.technique}; channels: {', '.join(channels)}"
                self.inspect = None
                return
            texture = channels[channel]
            if (mode if mode != "auto" else auto_mode(channel, texture)) == "range":
                self.inspect_range = value_range(texture)

    # Panels and animation.
    def toggle_panel(self) -> None:
        self.show_panel = not self.show_panel

    def set_time(self, value: float) -> None:
        """Scene time of an animated preset: its meshes move, edited materials and lights stay."""
        if self.scene_at is None:
            return
        self.time = float(value)
        fresh = {o.name: o for o in self.scene_at(self.time).objects}
        for obj in self.scene.objects:
            if obj.name in fresh and fresh[obj.name].mesh is not obj.mesh:
                obj.mesh = fresh[obj.name].mesh
        self.changed()

    def play(self, on: bool = True) -> None:
        self.playing = bool(on) and self.scene_at is not None
