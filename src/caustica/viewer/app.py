"""The viewer window: glfw + moderngl over the window's context, Dear ImGui (imgui-bundle) for the panel.

Every frame runs the technique's passes on a :class:`GpuDevice` built over the
window's own GL context, draws the ``color`` texture into the view (no
readback), then the panel and the frame-time overlay. Input arrives from the
mouse and keyboard or from a script of events (:meth:`Viewer.apply`), so
tests and ``--script`` runs drive it exactly as a person would. What they edit
is the headless :class:`~caustica.viewer.state.ViewerState` (``viewer.state``).
"""
from __future__ import annotations

import dataclasses
import functools
import os
import time
from collections import deque

import numpy as np

from ..errors import CausticaError
from ..scene import Scene
from .frames import (
    LiveImage,
    LiveRenderer,
    channel_textures,
    prune_meshes,
    release_device,
)
from .panel import PANEL_WIDTH
from .state import ViewerState, animated_variant  # noqa: F401 (animated_variant: imported from here too)

NO_DISPLAY = "no display found (DISPLAY is not set); use 'caustica render' for headless images"
MISSING_PACKAGES = "the viewer needs glfw and imgui-bundle; run: pip install 'caustica[viewer]'"
ANIMATION_STEP = 1.0 / 30.0  # seconds of scene time per frame in scripted runs (reproducible)


class ViewerError(CausticaError):
    """The viewer cannot open: no display, no GL 4.3 window, or its packages are missing."""


def check_display() -> None:
    """Raise ViewerError with the hint to render headless when no display is reachable."""
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ViewerError(NO_DISPLAY)


@dataclasses.dataclass
class CloseReport:
    """What closing left behind: the last GL error and GL objects still alive (both should be empty)."""

    gl_error: str
    live_objects: dict
    earlier_errors: list = dataclasses.field(default_factory=list)  # GL errors collected while running


class _StateField:
    """A Viewer attribute that is its editing model's (``viewer.state.<name>``), read and written."""

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, viewer, owner=None):
        return self if viewer is None else getattr(viewer.state, self.name)

    def __set__(self, viewer, value):
        setattr(viewer.state, self.name, value)


def _forward(method):
    """A Viewer method that runs ``method`` of its editing model (same name, signature and docstring)."""
    @functools.wraps(method)
    def forward(self, *args, **kwargs):
        return method(self.state, *args, **kwargs)
    return forward


class Viewer:
    """An interactive window over ``scene``. Use :meth:`run`, or :meth:`step` frame by frame, then :meth:`close`.

    The scene, camera, technique and other edits live in ``self.state`` (a :class:`ViewerState`); the
    viewer reads and writes them under the same names (``viewer.technique``, ``viewer.orbit_by``...).
    """

    scene = _StateField()
    orbit = _StateField()
    technique = _StateField()
    params = _StateField()
    spp = _StateField()
    antialias = _StateField()
    exposure = _StateField()
    tonemap = _StateField()
    second = _StateField()
    second_params = _StateField()
    difference = _StateField()
    difference_gain = _StateField()
    inspect = _StateField()
    inspect_mode = _StateField()
    inspect_range = _StateField()
    inspect_auto = _StateField()
    scene_at = _StateField()
    time = _StateField()
    playing = _StateField()
    show_panel = _StateField()
    show_overlay = _StateField()
    error = _StateField()
    state_version = _StateField()

    def __init__(self, scene: Scene, technique: str = "auto", params: dict | None = None, size=None,
                 spp: int = 1, exposure: float = 0.0, panel: bool = True, overlay: bool = True,
                 title: str | None = None, fixed_step: bool = False, tonemap: str = "clip",
                 antialias: str = "none"):
        # Validates the technique, parameters, spp, tone curve and anti-aliasing before a window opens.
        self.state = ViewerState(scene, technique, params, spp, exposure, panel, overlay,
                                 viewport=lambda: self.layout()[0][2:], tonemap=tonemap, antialias=antialias)
        self.profile, self.fixed_step = False, fixed_step
        self.pass_gl_errors: set[str] = set()  # GL errors the technique's passes left (reported, not raised)
        self.frame_index, self.frame_ms = 0, deque(maxlen=60)
        self.main = self.other = LiveImage(technique)
        self._drag = {"button": None, "pos": (0.0, 0.0), "shift": False}
        self._cursor_over_panel = False
        self.overlay_rect = None  # where ImGui last drew the overlay (x, y, w, h from the lower left)
        self.caption_rects: list = []  # and the views' captions (technique names, a CPU render's progress)
        self._script: deque = deque()
        self._grab, self._grab_path, self.last_window = False, None, None
        self._last_time = time.perf_counter()
        self._open_window(tuple(size or scene.camera.size), title or f"caustica: {scene.name}")

    # Open the window, the GL context over it, the renderer's device, and ImGui.
    def _open_window(self, size, title) -> None:
        check_display()
        from ..gpu.context import headless_context_exists

        # After a headless (EGL) render in this process a GLX window fails in X (BadAccess at
        # glXMakeCurrent), so the window's context is EGL then; otherwise GLX, whose swaps through
        # Xvfb are faster. PyOpenGL (ImGui's renderer) must then look for contexts through EGL.
        egl = headless_context_exists()
        if egl:
            os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
        try:
            import glfw
            from imgui_bundle import imgui
            from imgui_bundle.python_backends.glfw_backend import GlfwRenderer
        except ImportError:
            raise ViewerError(MISSING_PACKAGES) from None
        import moderngl

        from ..gpu.device import GpuDevice
        from .display import Display
        from .ui_layer import UiLayer

        if not glfw.init():
            raise ViewerError(NO_DISPLAY.replace("DISPLAY is not set", f"cannot open display {os.environ.get('DISPLAY')}"))
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 4)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        if egl:
            glfw.window_hint(glfw.CONTEXT_CREATION_API, glfw.EGL_CONTEXT_API)
        self.view_size = (int(size[0]), int(size[1]))
        width, height = self._window_size()
        self.window = glfw.create_window(width, height, title, None, None)
        if not self.window:
            glfw.terminate()
            raise ViewerError("cannot open an OpenGL 4.3 core window on this display; use 'caustica render' instead")
        glfw.make_context_current(self.window)
        glfw.swap_interval(0)  # frame times measure the renderer, not the monitor
        self.glfw, self._keys = glfw, _key_table()
        if egl:
            moderngl.init_context()  # moderngl's default loader finds the current EGL context
            self.ctx = moderngl.get_context()
        else:
            self.ctx = moderngl.create_context(require=430)
        if self.ctx.version_code < 430:
            version = f"{self.ctx.version_code // 100}.{self.ctx.version_code % 100 // 10}"
            raise ViewerError(f"the window's OpenGL is {version}, 4.3 core is required; use 'caustica render' instead")
        self.ctx.gc_mode = "auto"  # release GL objects the passes drop without release() (one VAO a frame otherwise)
        self.device = GpuDevice(self.ctx)
        self.live = LiveRenderer(self.device)
        self.display = Display(self.ctx)
        self.ui = UiLayer(self.ctx)
        self.imgui = imgui
        imgui.create_context()
        imgui.get_io().set_ini_filename(None)  # no imgui.ini in the working directory
        self.gui = GlfwRenderer(self.window, attach_callbacks=False)
        glfw.set_key_callback(self.window, self._on_key)
        glfw.set_char_callback(self.window, self._on_char)
        glfw.set_cursor_pos_callback(self.window, self._on_cursor)
        glfw.set_mouse_button_callback(self.window, self._on_button)
        glfw.set_scroll_callback(self.window, self._on_scroll)
        glfw.set_window_size_callback(self.window, self.gui.resize_callback)

    def _window_size(self) -> tuple[int, int]:
        views = 2 if self.second else 1
        return self.view_size[0] * views + (PANEL_WIDTH if self.show_panel else 0), self.view_size[1]

    def _fit_window(self) -> None:
        """Resize the window so that each view keeps ``view_size`` (after toggling the panel or side by side)."""
        self.glfw.set_window_size(self.window, *self._window_size())

    # Layout: views from the left, the panel on the right.
    def layout(self) -> list[tuple[int, int, int, int]]:
        """View rectangles (x, y, w, h) from the window's lower left: one, or two side by side."""
        width, height = self.glfw.get_framebuffer_size(self.window)
        usable = max(1, width - (PANEL_WIDTH if self.show_panel else 0))
        if self.state.side_by_side:
            half = usable // 2
            return [(0, 0, half, height), (half, 0, half, height)]
        return [(0, 0, usable, height)]

    # One frame: input, animation, render, draw, panel, swap.
    def step(self) -> None:
        glfw, imgui = self.glfw, self.imgui
        glfw.poll_events()
        if self._script:
            self._next_event()
        self._advance_animation()
        rects = self.layout()
        camera = self.orbit.camera(rects[0][2:])
        self.main = self._render("main", self.technique, self.params, camera)
        if self.second:
            self.other = self._render("second", self.second, self.second_params, camera)
        # Draw the views.
        self.ctx.screen.use()
        width, height = glfw.get_framebuffer_size(self.window)
        self.ctx.screen.viewport = (0, 0, width, height)
        # Clear only what neither the views nor the (opaque) panel cover: a CPU render pending.
        drawn = rects if self.main.color is not None else []
        if len(drawn) > 1 and self.other.color is None:
            drawn = drawn[:1]
        covered = max((x + w for x, _, w, _ in drawn), default=0)
        uncovered = width - covered - (PANEL_WIDTH if self.show_panel else 0)
        if uncovered > 0:
            self.ctx.clear(0.1, 0.1, 0.11, viewport=(covered, 0, uncovered, height))
        self._draw_views(rects)
        # The panel and the overlay: ImGui redraws its layer after input or now and then; composited every frame.
        self._collect_gl_error("drawing the views")
        if self.show_panel or self.show_overlay:
            if self.ui.due((width, height)):
                self.ui.redraw((width, height), self._draw_ui)
                self.ctx.screen.use()
                self.ctx.screen.viewport = (0, 0, width, height)
            panel = (width - PANEL_WIDTH, 0, PANEL_WIDTH, height) if self.show_panel else None
            self.ui.composite(self.display, (width, height), panel,
                              [self.overlay_rect, *self.caption_rects] if self.show_overlay and self.overlay_rect
                              else [])
        if self._grab or self._grab_path:
            data = self.ctx.screen.read(viewport=(0, 0, width, height), components=3)
            self.last_window = np.frombuffer(data, dtype=np.uint8).reshape(height, width, 3)[::-1].copy()
            if self._grab_path:
                self._save_window(self._grab_path)
            self._grab, self._grab_path = False, None
        glfw.swap_buffers(self.window)
        now = time.perf_counter()
        self.frame_ms.append((now - self._last_time) * 1000.0)
        self._last_time = now
        self.frame_index += 1

    def _draw_ui(self) -> None:
        """One ImGui frame of the panel and overlay, rendered into the bound target (the UI layer)."""
        from .panel import draw_captions, draw_overlay, draw_panel

        imgui = self.imgui
        self.gui.process_inputs()
        imgui.new_frame()
        if self.show_panel:
            draw_panel(self)
        if self.show_overlay:
            draw_overlay(self)
            self.caption_rects = draw_captions(self, self.layout())
        imgui.render()
        self.gui.render(imgui.get_draw_data())

    def _render(self, slot: str, technique: str, params: dict, camera) -> LiveImage:
        try:
            image = self.live.render(slot, self.scene, camera, technique, params, self.spp, self.profile,
                                     state_key=(self.state_version, self.time), antialias=self.antialias)
        except CausticaError as exc:
            self.error = f"{technique}: {exc}"
            return LiveImage(technique, error=str(exc))
        finally:
            # Collect the passes' GL error flag here: PyOpenGL (the panel) would raise it as its own.
            self._collect_gl_error(technique)
        if image.error:
            self.error = f"{technique}: {image.error}"
        return image

    def _collect_gl_error(self, where: str) -> None:
        error = self.ctx.error
        if error != "GL_NO_ERROR":
            self.pass_gl_errors.add(f"{where}: {error}")

    def _draw_views(self, rects) -> None:
        if self.main.color is None:
            return
        if self.inspect is not None:
            texture = channel_textures(self.main.channels).get(self.inspect)
            if texture is not None:
                self._draw_channel(texture, rects[0])
                if self.second and len(rects) > 1 and self.other.color is not None:
                    self.display.draw(self.other.color, rects[1], "color", self.exposure, self.other.supersampling,
                                      tonemap=self.tonemap)
                return
        if self.second and self.difference and self.other.color is not None:
            same_k = self.main.supersampling == self.other.supersampling
            self.display.draw(self.main.color, rects[0], "difference", self.exposure, self.main.supersampling,
                              other=self.other.color if same_k else self.main.color, gain=self.difference_gain)
            return
        self.display.draw(self.main.color, rects[0], "color", self.exposure, self.main.supersampling,
                          tonemap=self.tonemap)
        if self.second and len(rects) > 1 and self.other.color is not None:
            self.display.draw(self.other.color, rects[1], "color", self.exposure, self.other.supersampling,
                              tonemap=self.tonemap)

    def _draw_channel(self, texture, rect) -> None:
        from .display import auto_mode, value_range

        mode = auto_mode(self.inspect, texture) if self.inspect_mode == "auto" else self.inspect_mode
        if mode == "range" and self.inspect_auto and self.frame_index % 10 == 0:
            self.inspect_range = value_range(texture)
        k = max(1, texture.size[0] // max(1, rect[2]))  # the frame's k x k samples (display letterboxes a misfit)
        self.display.draw(texture, rect, mode, self.exposure, k, self.inspect_range, tonemap=self.tonemap)

    def _advance_animation(self) -> None:
        now = time.perf_counter()
        if self.scene_at is not None and self.playing:
            self.set_time(self.time + (ANIMATION_STEP if self.fixed_step else min(0.1, now - self._last_time)))

    def run(self, frames: int | None = None, script=()) -> None:
        """Show frames until the window closes, or ``frames`` frames and the whole ``script`` have run."""
        self._script.extend(script)
        while not self.glfw.window_should_close(self.window):
            if frames is not None and self.frame_index >= frames and not self._script:
                break
            self.step()

    # Scripted input: the same actions the mouse, keys and panel trigger.
    def apply(self, event) -> None:
        """Run one event: a tuple ``(name, *args)``, e.g. ``("orbit", 40, 0)``, ``("param", "tir_mode", "reflect")``."""
        name, *args = event
        action = EVENTS.get(name)
        if action is None:
            raise CausticaError(f"unknown viewer event '{name}'; use one of {', '.join(sorted(EVENTS))}")
        action(self, *args)
        self.ui.touch()

    def _next_event(self) -> None:
        event = self._script[0]
        if event[0] == "wait" and int(event[1]) > 1:
            self._script[0] = ("wait", int(event[1]) - 1)
            return
        self._script.popleft()
        self.apply(event)

    # Edits: the editing model's, plus what they change in the window (its size, the GPU's meshes).
    changed = _forward(ViewerState.changed)
    camera = _forward(ViewerState.camera)
    scene_view = _forward(ViewerState.scene_view)
    orbit_by = _forward(ViewerState.orbit_by)
    pan_by = _forward(ViewerState.pan_by)
    zoom_by = _forward(ViewerState.zoom_by)
    frame_scene = _forward(ViewerState.frame_scene)
    reset_camera = _forward(ViewerState.reset_camera)
    set_technique = _forward(ViewerState.set_technique)
    set_param = _forward(ViewerState.set_param)
    set_spp = _forward(ViewerState.set_spp)
    set_antialias = _forward(ViewerState.set_antialias)
    cycle_antialias = _forward(ViewerState.cycle_antialias)
    set_material = _forward(ViewerState.set_material)
    object_technique = _forward(ViewerState.object_technique)
    set_object_technique = _forward(ViewerState.set_object_technique)
    move_light = _forward(ViewerState.move_light)
    drag_light = _forward(ViewerState.drag_light)
    play = _forward(ViewerState.play)

    def set_inspect(self, channel: str | None, mode: str = "auto") -> None:
        """:meth:`ViewerState.set_inspect`, the name checked against the last frame's channels."""
        channels = channel_textures(self.main.channels) if self.main.color is not None else None
        self.state.set_inspect(channel, mode, channels)

    def set_side_by_side(self, technique: str | None, difference: bool = False) -> None:
        """:meth:`ViewerState.set_side_by_side`; the window refits when the number of views changes."""
        was = self.state.side_by_side
        self.state.set_side_by_side(technique, difference)
        if self.state.side_by_side != was:
            self._fit_window()

    def toggle_panel(self) -> None:
        self.state.toggle_panel()
        self._fit_window()

    def set_time(self, value: float) -> None:
        """Scene time of an animated preset: its meshes move (the dropped ones leave the GPU), edits stay."""
        self.state.set_time(value)
        if self.scene_at is not None:
            prune_meshes(self.device, self.scene)

    # Screenshots: the rendered image (as 'caustica render' writes it) or the whole window.
    def image(self) -> np.ndarray:
        """The main view's last frame as a float32 linear (H, W, 3) image, row 0 at the top."""
        from ..gpu.readback import box_downsample, read_rgb

        if self.main.pending:
            self.live.wait("main")
            self.step()
        if self.main.color is None:
            raise CausticaError(f"no image to save: {self.error or 'nothing rendered yet'}")
        return box_downsample(read_rgb(self.main.color), self.main.supersampling).astype(np.float32)

    def screenshot(self, path) -> str:
        """Write the last frame: .png (sRGB after the exposure and tone curve, as the view shows it) or .exr
        (linear float)."""
        from ..images import write_image

        return str(write_image(path, self.image(), exposure=self.exposure, tonemap=self.tonemap))

    def grab_window(self) -> np.ndarray:
        """Draw one more frame and return the whole window as uint8 (H, W, 3), panel included."""
        self._grab = True
        self.step()
        return self.last_window

    def screenshot_window(self, path) -> str:
        """Write the whole window, panel included, as PNG."""
        self.grab_window()
        return self._save_window(path)

    def _save_window(self, path) -> str:
        from PIL import Image

        from ..atomic import write_atomic

        pixels = self.last_window
        return str(write_atomic(path, lambda tmp: Image.fromarray(pixels).save(tmp, format="PNG")))

    # Input callbacks: ImGui first; the view gets what the panel does not want.
    def _on_char(self, window, char) -> None:
        self.gui.char_callback(window, char)
        self.ui.touch()

    def _on_key(self, window, key, scancode, action, mods) -> None:
        self.gui.keyboard_callback(window, key, scancode, action, mods)
        self.ui.touch()
        if action == self.glfw.RELEASE or self.imgui.get_io().want_capture_keyboard:
            return
        glfw = self.glfw
        step = 0.05 * float(np.linalg.norm(np.subtract(*self.scene.bounds())))
        light_keys = {glfw.KEY_LEFT: (-step, 0, 0), glfw.KEY_RIGHT: (step, 0, 0), glfw.KEY_UP: (0, 0, -step),
                      glfw.KEY_DOWN: (0, 0, step), glfw.KEY_PAGE_UP: (0, step, 0), glfw.KEY_PAGE_DOWN: (0, -step, 0)}
        if key in light_keys and self.scene.lights:
            self.move_light(0, light_keys[key])
        elif key in self._keys:
            self._keys[key](self)

    def _touch_ui_under(self, x: float) -> None:
        """Mouse input: ImGui runs while the cursor is over the panel, crosses its edge, or drags a widget."""
        over = self.show_panel and x >= self.glfw.get_window_size(self.window)[0] - PANEL_WIDTH
        if over or over != self._cursor_over_panel or self.imgui.get_io().want_capture_mouse:
            self.ui.touch()
        self._cursor_over_panel = over

    def _on_cursor(self, window, x, y) -> None:
        self.gui.mouse_callback(window, x, y)
        self._touch_ui_under(x)
        button, (last_x, last_y) = self._drag["button"], self._drag["pos"]
        self._drag["pos"] = (x, y)
        if button is None:
            return
        dx, dy = x - last_x, y - last_y
        if button == self.glfw.MOUSE_BUTTON_LEFT and self._drag["shift"]:
            self.drag_light(dx, dy)
        elif button == self.glfw.MOUSE_BUTTON_LEFT:
            self.orbit_by(dx, dy)
        else:
            self.pan_by(dx, dy)

    def _on_button(self, window, button, action, mods) -> None:
        self.gui.mouse_button_callback(window, button, action, mods)
        self._touch_ui_under(self.glfw.get_cursor_pos(window)[0])
        if action == self.glfw.PRESS and not self.imgui.get_io().want_capture_mouse:
            self._drag.update(button=button, pos=self.glfw.get_cursor_pos(window),
                              shift=bool(mods & self.glfw.MOD_SHIFT))
        elif action == self.glfw.RELEASE:
            self._drag["button"] = None

    def _on_scroll(self, window, x_offset, y_offset) -> None:
        self.gui.scroll_callback(window, x_offset, y_offset)
        self._touch_ui_under(self.glfw.get_cursor_pos(window)[0])
        if not self.imgui.get_io().want_capture_mouse:
            self.zoom_by(y_offset)

    # Close: release every GL object, check for errors and leaks, destroy the window.
    def close(self) -> CloseReport:
        """Release GL objects and the window; returns the GL error state and any objects left alive."""
        if getattr(self, "window", None) is None:
            return CloseReport("GL_NO_ERROR", {})
        from OpenGL import GL

        self._collect_gl_error("before close")
        GL.glUseProgram(0)  # a program still in use is only flagged for deletion
        GL.glBindVertexArray(0)
        self.live.release()
        self.display.release()
        self.ui.release()
        self.gui.shutdown()
        self.imgui.destroy_context()
        release_device(self.device)
        import gc

        gc.collect()  # dropped moderngl objects release their GL names now (gc_mode 'auto')
        error = self.ctx.error
        live = live_gl_objects()
        self.ctx.release()
        self.glfw.destroy_window(self.window)
        self.glfw.terminate()
        self.window = None
        return CloseReport(error, live, sorted(self.pass_gl_errors))

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def live_gl_objects(max_name: int = 4096) -> dict:
    """GL object names still alive in the current context, by kind (names are small integers on Mesa)."""
    from OpenGL import GL

    checks = {"texture": GL.glIsTexture, "buffer": GL.glIsBuffer, "framebuffer": GL.glIsFramebuffer,
              "renderbuffer": GL.glIsRenderbuffer, "program": GL.glIsProgram, "vertex_array": GL.glIsVertexArray,
              "shader": GL.glIsShader, "query": GL.glIsQuery}
    alive = {}
    for kind, check in checks.items():
        names = [n for n in range(1, max_name) if check(n)]
        if names:
            alive[kind] = names
    return alive


def _screenshot_key(viewer: Viewer) -> None:
    path = f"caustica-view-{viewer.frame_index:05d}.png"
    viewer.screenshot(path)
    print(f"wrote {path}")


def _cycle_inspector(viewer: Viewer) -> None:
    names = [None, *channel_textures(viewer.main.channels)]
    viewer.set_inspect(names[(names.index(viewer.inspect) + 1) % len(names)] if viewer.inspect in names else None)


def _key_table() -> dict:
    import glfw

    return {
        glfw.KEY_F: Viewer.frame_scene, glfw.KEY_R: Viewer.reset_camera, glfw.KEY_TAB: Viewer.toggle_panel,
        glfw.KEY_P: lambda v: v.play(not v.playing), glfw.KEY_I: _cycle_inspector, glfw.KEY_S: _screenshot_key,
        glfw.KEY_O: lambda v: setattr(v, "show_overlay", not v.show_overlay), glfw.KEY_A: Viewer.cycle_antialias,
        glfw.KEY_ESCAPE: lambda v: v.glfw.set_window_should_close(v.window, True),
        glfw.KEY_Q: lambda v: v.glfw.set_window_should_close(v.window, True),
    }


EVENTS = {
    "orbit": Viewer.orbit_by, "pan": Viewer.pan_by, "zoom": Viewer.zoom_by,
    "frame": Viewer.frame_scene, "reset": Viewer.reset_camera,
    "technique": Viewer.set_technique, "param": Viewer.set_param, "material": Viewer.set_material,
    "object_technique": Viewer.set_object_technique,
    "light": Viewer.move_light, "drag_light": Viewer.drag_light,
    "inspect": Viewer.set_inspect, "side_by_side": Viewer.set_side_by_side,
    "exposure": lambda v, value: setattr(v, "exposure", float(value)),
    "tonemap": lambda v, value: setattr(v, "tonemap", value),
    "spp": Viewer.set_spp, "antialias": Viewer.set_antialias,
    "overlay": lambda v, on=True: setattr(v, "show_overlay", bool(on)),
    "time": Viewer.set_time, "play": Viewer.play, "panel": lambda v, on=True: on != v.show_panel and v.toggle_panel(),
    "screenshot": Viewer.screenshot, "screenshot_window": Viewer.screenshot_window,
    "wait": lambda v, frames=1: None, "close": lambda v: v.glfw.set_window_should_close(v.window, True),
}

# 'caustica view --script FILE': what the option takes (cli.py's _read_script reads the file, Viewer.run runs it).
SCRIPT_HELP = ("a JSON file holding a list of [event, args...] lists, applied in order, one a frame "
               "([\"wait\", N] takes N frames), e.g. [[\"orbit\", 40, 0], [\"technique\", \"depth-search\"], "
               "[\"param\", \"iterations\", 3], [\"wait\", 10], [\"screenshot\", \"a.png\"]]; events: "
               + ", ".join(sorted(EVENTS)) + "; the window closes once the script and --frames are both done "
               "(without --frames it stays open)")
