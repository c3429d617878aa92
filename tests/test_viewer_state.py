"""The viewer's editing model (``ViewerState``) with no display, no window and no GL context."""
from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

import caustica
from caustica.errors import CausticaError, TechniqueError
from caustica.techniques import get_technique
from caustica.viewer.state import ViewerState


def state_of(name: str, technique: str = "env-map", **kwargs) -> ViewerState:
    return ViewerState(caustica.load_scene(name), technique, **kwargs)


def test_the_state_module_needs_no_window_packages():
    code = ("import sys, caustica.viewer.state\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('glfw', 'imgui_bundle', 'OpenGL')))")
    done = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True, timeout=120)
    assert done.stdout.strip() == "[]"


def test_bad_input_is_refused_before_a_window_opens(monkeypatch):
    from caustica.viewer import Viewer

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    scene = caustica.load_scene("glass-sphere")
    with pytest.raises(TechniqueError, match="tir_mode 'bogus' must be one of") as state_error:
        ViewerState(scene, "image-space", {"tir_mode": "bogus"})
    with pytest.raises(TechniqueError) as viewer_error:  # the state's error, not "no display found"
        Viewer(scene, "image-space", {"tir_mode": "bogus"})
    assert str(viewer_error.value) == str(state_error.value)
    with pytest.raises(TechniqueError, match="spp 3 is not a square"):
        ViewerState(scene, spp=3)


def test_a_rejected_parameter_is_reported_and_not_applied():
    state = state_of("glass-sphere", "image-space", params={"tir_mode": "reflect"})
    with pytest.raises(TechniqueError) as refused:
        get_technique("image-space").make_params(tir_mode="bogus")
    state.set_param("tir_mode", "bogus")
    assert state.error == str(refused.value)
    assert state.params == {"tir_mode": "reflect"} and state.state_version == 0
    state.set_param("tir_mode", "keep-t1")
    assert state.params == {"tir_mode": "keep-t1"} and state.error is None and state.state_version == 1


def test_set_technique_keeps_only_the_parameters_the_new_one_has():
    state = state_of("glass-sphere", "image-space", params={"tir_mode": "reflect", "nearby": "planes",
                                                           "shadow_map_size": 512})
    state.inspect, state.error = "back_surface", "old"
    state.set_technique("depth-search")
    assert state.technique == "depth-search"
    assert state.params == {"nearby": "planes", "shadow_map_size": 512}  # depth-search has no tir_mode
    assert state.inspect is None and state.error is None and state.state_version == 1
    with pytest.raises(TechniqueError, match="unknown technique 'nope'"):
        state.set_technique("nope")
    assert state.technique == "depth-search" and state.state_version == 1


def test_the_second_technique_takes_its_own_parameters():
    state = state_of("glass-sphere")
    state.set_side_by_side("image-space")
    assert state.side_by_side and state.second == "image-space"
    state.set_param("tir_mode", "reflect", second=True)
    assert state.second_params == {"tir_mode": "reflect"} and state.params == {}
    state.set_param("tir_mode", "bogus", second=True)
    assert "tir_mode 'bogus'" in state.error and state.second_params == {"tir_mode": "reflect"}
    state.set_side_by_side("env-map", difference=True)  # a new second starts from its defaults
    assert not state.side_by_side and state.difference and state.second_params == {}
    state.set_side_by_side(None, difference=True)
    assert state.second is None and not state.difference
    with pytest.raises(TechniqueError):
        state.set_side_by_side("nope")
    assert state.second is None


def test_orbit_pan_zoom_frame_and_reset_move_the_camera():
    state = state_of("glass-sphere")
    home = state.camera()
    assert home.size == state.scene.camera.size  # no window: the scene camera's size
    np.testing.assert_allclose(home.position, state.scene.camera.position, atol=1e-9)
    distance = np.linalg.norm(home.position - home.look_at)
    state.orbit_by(40, -15)
    moved = state.camera()
    assert np.linalg.norm(moved.position - home.position) > 0.1
    assert np.linalg.norm(moved.position - moved.look_at) == pytest.approx(distance)
    state.zoom_by(2)
    assert state.orbit.distance == pytest.approx(0.81 * distance)
    state.pan_by(20, 0)
    assert not np.allclose(state.camera().look_at, home.look_at)
    state.frame_scene()
    np.testing.assert_allclose(state.camera().look_at, state.scene.bounds().mean(axis=0), atol=1e-9)
    state.reset_camera()
    np.testing.assert_allclose(state.camera().position, home.position, atol=1e-9)
    assert state.state_version == 5


def test_the_viewport_sets_the_camera_size_and_the_pan_scale():
    scene = caustica.load_scene("glass-sphere")
    shifts = []
    for height in (50, 500):
        state = ViewerState(scene, viewport=lambda height=height: (100, height))
        assert state.camera().size == (100, height) and state.camera((8, 6)).size == (8, 6)
        target = state.orbit.target.copy()
        state.pan_by(10, 0)
        shifts.append(np.linalg.norm(state.orbit.target - target))
    assert shifts[0] == pytest.approx(10 * shifts[1])  # a pixel of a 10x smaller view covers 10x more


def test_scene_view_is_the_scene_under_the_current_camera():
    state = state_of("caustic-sphere")
    state.orbit_by(30, 0)
    version = state.state_version
    view = state.scene_view((64, 48))
    assert view.camera.size == (64, 48)
    np.testing.assert_allclose(view.camera.position, state.camera().position)
    assert view.objects is state.scene.objects and view.lights is state.scene.lights
    assert state.scene.camera.size == (512, 512)  # the edited scene keeps its own camera
    state.object_technique("ball")
    assert not state.side_by_side
    assert state.state_version == version  # reads are not edits


def test_set_material_changes_the_named_object_or_reports_why_not():
    state = state_of("caustic-sphere")
    state.set_material("ball", "ior", 1.33)
    state.set_material(1, "color", np.array([0.2, 0.3, 0.4]))
    assert state.scene.objects[0].material.ior == pytest.approx(1.33)
    np.testing.assert_allclose(state.scene.objects[1].material.color, [0.2, 0.3, 0.4])
    assert state.state_version == 2
    state.set_material("ball", "shininess", 3.0)
    assert state.error.startswith("ball: ") and "shininess" in state.error and state.state_version == 2
    with pytest.raises(CausticaError, match="no object named 'lamp'; objects: ball, floor"):
        state.set_material("lamp", "ior", 1.5)


def test_set_object_technique_switches_to_per_object_with_the_override():
    state = state_of("tvcg-fig11", "depth-search")
    assert [state.object_technique(o.name) for o in state.scene.objects_of("glass")] == ["depth-search"] * 3
    state.set_object_technique("sphere-0", "env-map")
    assert state.technique == "per-object" and state.error is None
    assert state.params == {"techniques": {"sphere-0": "env-map"}, "default": "depth-search"}
    assert [state.object_technique(i) for i in range(3)] == ["env-map", "depth-search", "depth-search"]
    assert state.state_version == 2  # the switch to per-object, then the override
    state.set_object_technique("floor", "env-map")
    assert state.error == "floor is diffuse; only glass objects choose a technique"
    assert state.params["techniques"] == {"sphere-0": "env-map"} and state.state_version == 2


def test_a_per_object_choice_keeps_the_caustics_on():
    state = state_of("tvcg-fig11", "caustic-mapping")
    state.set_object_technique("sphere-1", "image-space")
    assert state.technique == "per-object+caustic-mapping"
    assert state.object_technique("sphere-1") == "image-space"
    state.set_param("depth-search.iterations", 0)
    state.set_technique("per-object")  # caustics off: the qualified parameter stays
    assert state.params["depth-search.iterations"] == 0


def test_move_and_drag_light():
    state = state_of("caustic-sphere")
    start = state.scene.lights[0].position.copy()
    state.move_light(0, delta=(0.0, 1.0, 0.0))
    np.testing.assert_allclose(state.scene.lights[0].position, start + [0.0, 1.0, 0.0])
    state.move_light(0, position=start)
    np.testing.assert_allclose(state.scene.lights[0].position, start)
    camera = state.camera()
    forward = camera.look_at - camera.position
    state.drag_light(30, 0)  # right in the view plane
    moved = state.scene.lights[0].position - start
    assert np.linalg.norm(moved) > 1e-3
    assert abs(moved @ forward) < 1e-9 * np.linalg.norm(forward)
    assert moved @ np.cross(forward, camera.up) > 0
    before = state.scene.lights[0].position.copy()
    state.drag_light(0, -30)  # up the screen
    assert (state.scene.lights[0].position - before) @ camera.up > 0
    assert state.state_version == 4


def test_dragging_a_directional_light_turns_it():
    state = state_of("caustics-pool")
    start = state.scene.lights[0].direction.copy()
    state.drag_light(25, 0)
    assert not np.allclose(state.scene.lights[0].direction, start)
    assert not hasattr(state.scene.lights[0], "position")
    empty = state_of("glass-sphere")  # no lights: nothing to drag
    empty.drag_light(25, 0)
    assert empty.state_version == 0


class _Texture:
    """What set_inspect reads of a moderngl texture."""

    depth, components, dtype, size = False, 1, "f4", (4, 1)

    def read(self) -> bytes:
        return np.array([0.0, 1.0, 2.0, 3.0], "f4").tobytes()


def test_set_inspect_checks_the_channel_and_measures_its_range():
    state = state_of("glass-sphere")
    channels = {"depth": _Texture()}
    state.set_inspect("nothing", channels=channels)
    assert state.inspect is None and state.error == "no channel 'nothing' in env-map; channels: depth"
    state.set_inspect("depth", "color", channels=channels)  # not a range view: the range stays
    assert state.inspect == "depth" and state.inspect_range == (0.0, 1.0)
    state.set_inspect("depth", channels=channels)  # 'auto' views a depth as a range
    assert state.inspect_mode == "auto" and state.inspect_range == pytest.approx((0.03, 2.97))
    state.set_inspect("later")  # before a frame: taken as asked
    assert state.inspect == "later" and state.inspect_auto
    assert state.state_version == 0  # inspecting does not re-render


def test_animation_time_moves_meshes_and_keeps_edits():
    state = state_of("caustics-pool")
    assert state.scene_at is not None
    state.set_material("water", "ior", 1.2)
    mesh = state.scene.objects[0].mesh
    state.play()
    assert state.playing
    state.set_time(0.5)
    water = state.scene.objects[0]
    assert state.time == 0.5 and water.mesh.content_hash() != mesh.content_hash()
    assert water.material.ior == pytest.approx(1.2) and state.state_version == 2
    still = state_of("glass-sphere")
    still.play()
    still.set_time(1.0)
    assert not still.playing and still.time == 0.0 and still.state_version == 0


def test_panels_and_spp():
    state = state_of("glass-sphere", overlay=False)
    assert state.show_panel and not state.show_overlay
    state.toggle_panel()
    assert not state.show_panel
    state.set_spp(4)
    assert state.spp == 4 and state.state_version == 1
    with pytest.raises(TechniqueError, match="spp 3 is not a square"):
        state.set_spp(3)
    assert state.spp == 4 and state.state_version == 1


def test_antialias_is_a_checked_render_setting():
    """``antialias`` (Renderer.render's modes) is "none" unless asked; a change re-renders (bumps the version),
    the A key cycles none, edge, msaa; a bad mode is Renderer.render's one-line error, the mode kept."""
    from caustica.errors import RenderOptionError

    state = state_of("glass-sphere")
    assert state.antialias == "none" and state_of("glass-sphere", antialias="msaa").antialias == "msaa"
    state.set_antialias("msaa")
    assert state.antialias == "msaa" and state.state_version == 1
    with pytest.raises(RenderOptionError, match=r"^antialias 'fxaa' is unknown; choose one of none, edge, msaa, adaptive$"):
        state.set_antialias("fxaa")
    with pytest.raises(RenderOptionError, match=r"^antialias 'adaptive' renders every frame twice"):
        state.set_antialias("adaptive")  # two frames each: Renderer.render's, not the viewer's
    assert state.antialias == "msaa" and state.state_version == 1
    seen = []
    for _ in range(3):
        state.cycle_antialias()
        seen.append(state.antialias)
    assert seen == ["none", "edge", "msaa"] and state.state_version == 4
    with pytest.raises(RenderOptionError, match="antialias 'smaa' is unknown"):
        state_of("glass-sphere", antialias="smaa")


def test_a_bad_antialias_is_refused_before_a_window_opens(monkeypatch):
    from caustica.errors import RenderOptionError
    from caustica.viewer import Viewer
    from caustica.viewer.app import EVENTS

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(RenderOptionError, match="antialias 'fxaa' is unknown"):  # not "no display found"
        Viewer(caustica.load_scene("glass-sphere"), "env-map", antialias="fxaa")
    viewer = Viewer.__new__(Viewer)
    viewer.state = state_of("glass-sphere")
    EVENTS["antialias"](viewer, "edge")
    assert viewer.antialias == viewer.state.antialias == "edge"


@pytest.mark.parametrize("antialias, spp", [("msaa", 1), ("edge", 1), ("msaa", 4)])
def test_the_live_view_is_the_renderers_antialiased_image(antialias, spp):
    """The viewer's raster frame with ``antialias`` (a headless device) shows Renderer.render's image of
    the same view with that mode, resolved to the view's size."""
    from caustica.gpu.device import GpuDevice
    from caustica.gpu.readback import read_rgb
    from caustica.viewer.frames import LiveRenderer

    scene = caustica.load_scene("door-mirror")
    camera = scene.camera.with_size(48, 36)
    device = GpuDevice()
    live = LiveRenderer(device)
    try:
        image = live.render("main", scene, camera, "plain", {}, spp, antialias=antialias)
        shown = read_rgb(image.color)
        assert image.supersampling == 1 and tuple(image.color.size) == (48, 36)
        view = dataclasses.replace(scene, camera=camera)
        expected = live.renderer.render(view, "plain", spp, antialias=antialias)
        np.testing.assert_allclose(shown, expected, atol=1e-6)
        assert not np.allclose(expected, live.renderer.render(view, "plain", spp), atol=1e-3)
    finally:
        live.release()
        device.release()


def test_the_viewer_reads_and_edits_its_state_under_the_old_names():
    """Viewer's fields and edit methods are its state's (checked on a viewer with no window)."""
    from caustica.viewer.app import EVENTS, Viewer

    viewer = Viewer.__new__(Viewer)
    viewer.state = state_of("caustic-sphere")
    viewer.orbit_by(40, 0)
    EVENTS["spp"](viewer, 4)
    EVENTS["material"](viewer, "ball", "ior", 1.4)
    viewer.technique = "image-space"
    viewer.exposure = 1.5
    assert viewer.state.state_version == viewer.state_version == 3
    assert viewer.state.spp == 4 and viewer.state.technique == "image-space" and viewer.state.exposure == 1.5
    assert viewer.scene is viewer.state.scene and viewer.scene.objects[0].material.ior == pytest.approx(1.4)
    np.testing.assert_allclose(viewer.camera().position, viewer.state.camera().position)


def test_tonemap_is_a_checked_display_setting():
    """``tonemap`` (the PNG tone curve of the view and its screenshots) is "clip" unless asked; it is only
    shown, so it re-renders nothing; a bad name is a one-line error naming the choices, before a window."""
    state = state_of("glass-sphere")
    assert state.tonemap == "clip"
    assert state_of("glass-sphere", tonemap="filmic").tonemap == "filmic"
    state.tonemap = "filmic"
    assert state.tonemap == "filmic" and state.state_version == 0
    with pytest.raises(CausticaError) as refused:
        state.tonemap = "aces"
    assert str(refused.value) == "unknown tonemap 'aces'; use one of clip, filmic"
    assert state.tonemap == "filmic"  # unchanged
    with pytest.raises(CausticaError) as at_start:
        state_of("glass-sphere", tonemap="reinhard")
    message = str(at_start.value)
    assert "\n" not in message and "'reinhard'" in message and "clip, filmic" in message


def test_a_bad_tonemap_is_refused_before_a_window_opens(monkeypatch):
    from caustica.viewer import Viewer

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(CausticaError, match="unknown tonemap 'aces'; use one of clip, filmic"):
        Viewer(caustica.load_scene("glass-sphere"), "env-map", tonemap="aces")  # not "no display found"


def test_the_default_technique_is_auto():
    """No technique given: the viewer, its state and 'caustica view' all plan one for the scene (auto)."""
    import inspect

    from caustica.cli import build_parser
    from caustica.viewer import Viewer

    assert ViewerState(caustica.load_scene("glass-sphere")).technique == "auto"
    assert inspect.signature(Viewer).parameters["technique"].default == "auto"
    assert build_parser().parse_args(["view", "glass-sphere"]).technique == "auto"


def test_panel_labels_fit_beside_their_widgets_for_every_technique():
    """The label column is as wide as the longest label (those cut to "shadow map si", "search distanc" and
    "internal bound" before), and the widgets keep a usable width, for every technique in the panel's list."""
    from caustica.viewer.panel import (FIXED_LABELS, LABEL_SPACING, MIN_WIDGET_WIDTH, label_column, panel_labels,
                                       technique_choices, technique_labels, text_width, widget_width)

    seen = set()
    for technique in technique_choices():
        labels = [*FIXED_LABELS, *technique_labels(technique)]
        column = label_column(labels)
        assert all(text_width(label) + LABEL_SPACING <= column for label in labels), technique
        assert widget_width(labels) >= MIN_WIDGET_WIDTH, technique
        seen.update(labels)
    assert {"shadow map size", "search distance", "internal bounces", "environment light samples"} <= seen
    # A whole panel: per-object with caustics (its techniques' parameters too) beside exact, materials, lights.
    state = state_of("tvcg-fig11", "per-object+caustic-mapping")
    state.set_side_by_side("exact")
    labels = panel_labels(state)
    assert {"absorption distance", "environment light samples", "search linear steps"} <= set(labels)
    assert any(label.endswith(" position") or label.endswith(" direction") for label in labels)
    assert widget_width(labels) >= MIN_WIDGET_WIDTH
    assert label_column(["ior##0", "technique##object1"]) == text_width("technique") + LABEL_SPACING


def test_the_label_sizes_are_imgui_s_own():
    """GLYPH_WIDTH and the style constants are what ImGui measures and uses (no window or GL needed)."""
    imgui = pytest.importorskip("imgui_bundle").imgui
    from caustica.viewer import panel

    imgui.create_context()
    try:
        io = imgui.get_io()
        io.set_ini_filename(None)  # no imgui.ini in the working directory
        io.backend_flags |= imgui.BackendFlags_.renderer_has_textures  # the font atlas is built without a renderer
        io.display_size = (800, 600)
        imgui.new_frame()
        for label in {*panel.FIXED_LABELS, *panel.technique_labels("exact"), *panel.technique_labels("depth-search")}:
            assert imgui.calc_text_size(label).x == panel.text_width(label)
        style = imgui.get_style()
        assert (style.item_inner_spacing.x, style.window_padding.x, style.scrollbar_size, style.indent_spacing) == (
            panel.LABEL_SPACING, panel.WINDOW_PADDING, panel.SCROLLBAR, panel.INDENT)
        imgui.end_frame()
    finally:
        imgui.destroy_context()


def test_views_are_captioned_with_their_techniques():
    from caustica.viewer.frames import LiveImage

    state = state_of("glass-sphere")
    done = LiveImage("env-map", color=object())
    assert state.view_captions(done) == [""]  # one current view: the overlay names it
    state.set_side_by_side("image-space")
    assert state.view_captions(done, LiveImage("image-space", color=object())) == ["env-map", "image-space"]
    state.set_side_by_side("mitsuba")
    assert state.view_captions() == ["env-map", "mitsuba (cached reference)"]
    state.set_side_by_side("image-space", difference=True)
    assert state.view_captions(done, done) == ["|env-map - image-space| x 4"]


def test_a_running_exact_render_shows_its_progress_in_the_caption():
    from caustica.viewer.frames import LiveImage

    state = state_of("glass-sphere")
    state.set_side_by_side("exact")
    starting = LiveImage("exact", pending=True, progress=0.0)
    preview = LiveImage("exact", color=object(), pending=True, progress=0.374, preview=4)
    assert state.view_captions(None, starting) == ["env-map", "exact: rendering 0%, nothing to show yet"]
    assert state.view_captions(None, preview)[1] == "exact: rendering 37%, 1/4 resolution"
    state.set_side_by_side("exact", difference=True)
    assert state.view_captions(None, preview) == ["|env-map - exact| x 4: exact rendering 37%, 1/4 resolution"]
    state.set_side_by_side("mitsuba")  # one stage, no estimate: the last image is shown meanwhile
    assert state.view_captions(None, LiveImage("mitsuba", color=object(), pending=True))[1] == (
        "mitsuba (cached reference): rendering, showing the last image")
    state.set_side_by_side(None)
    assert state.view_captions(LiveImage("env-map", color=object(), pending=True, progress=0.5, preview=8)) == [
        "env-map: rendering 50%, 1/8 resolution"]


def test_a_cpu_job_renders_in_stages_and_estimates_its_progress():
    """Stages of rising size; progress counts their pixels, the running stage's from the last one's rate."""
    import threading

    from caustica.viewer.frames import CpuJob, stage_sizes

    assert stage_sizes((512, 384)) == [(64, 48), (128, 96), (512, 384)]
    assert stage_sizes((64, 48)) == [(16, 12), (64, 48)]  # 8x6 is under MIN_PREVIEW
    assert stage_sizes((20, 20)) == [(20, 20)]
    now = [0.0]
    gates = {size: threading.Event() for size in stage_sizes((64, 48))}
    reached = threading.Semaphore(0)

    def render(size):
        reached.release()
        gates[size].wait(10)
        now[0] += 1.0 if size == (16, 12) else 0.0  # the preview takes one second of the fake clock
        return np.zeros((size[1], size[0], 3), np.float32)

    job = CpuJob("key", render, stage_sizes((64, 48)), clock=lambda: now[0]).start()
    assert reached.acquire(timeout=10) and job.progress() == 0.0 and job.image is None
    gates[(16, 12)].set()
    assert reached.acquire(timeout=10)  # the full stage started: 192 pixels a second so far
    assert job.done == 1 and job.image.shape == (12, 16, 3) and job.preview == 4
    assert job.progress() == pytest.approx(192 / (192 + 3072))
    now[0] += 5.0
    assert job.progress() == pytest.approx((192 + 5 * 192) / (192 + 3072))
    now[0] += 100.0
    assert job.progress() == pytest.approx((192 + 0.95 * 3072) / (192 + 3072))  # an estimate never says done
    gates[(64, 48)].set()
    job.thread.join(10)
    assert job.done == 2 and job.progress() == 1.0 and job.preview == 1 and job.error is None
    cancelled = CpuJob("key", render, [(16, 12), (64, 48)])
    cancelled.cancel()
    cancelled.start().thread.join(10)
    assert cancelled.done == 0 and cancelled.image is None


def test_the_live_exact_view_shows_a_preview_then_the_full_image(monkeypatch):
    """The viewer's exact frame (a headless device): progress and the 1/4 preview while the full stage runs,
    then the image at the view's size."""
    import threading
    import time

    from caustica.gpu.device import GpuDevice
    from caustica.viewer import frames

    release = threading.Event()
    staged = frames._cpu_render

    def gated(scene, camera, technique, params, spp):
        render = staged(scene, camera, technique, params, spp)
        return lambda size: (release.wait(60) if size == tuple(camera.size) else None, render(size))[1]

    monkeypatch.setattr(frames, "_cpu_render", gated)
    scene = caustica.load_scene("glass-sphere")
    camera = scene.camera.with_size(64, 48)
    params = {"caustic_photons": 0, "environment_samples": 0}
    device = GpuDevice()
    live = frames.LiveRenderer(device)
    try:
        first = live.render("second", scene, camera, "exact", params, state_key=1)
        assert first.pending and first.color is None and first.progress == 0.0
        job = live._jobs["second"]
        deadline = time.time() + 60
        while job.done < 1 and time.time() < deadline:
            job.thread.join(0.05)
        preview = live.render("second", scene, camera, "exact", params, state_key=1)
        assert preview.pending and tuple(preview.color.size) == (16, 12) and preview.preview == 4
        assert 0.0 < preview.progress < 1.0
        release.set()
        live.wait("second", 60)
        full = live.render("second", scene, camera, "exact", params, state_key=1)
        assert not full.pending and tuple(full.color.size) == (64, 48) and full.progress is None and full.preview == 1
    finally:
        release.set()
        live.release()
        device.release()


def test_the_script_help_says_what_script_takes():
    from caustica.viewer.app import EVENTS, SCRIPT_HELP

    assert SCRIPT_HELP.startswith("a JSON file") and '["wait", N]' in SCRIPT_HELP
    assert all(name in SCRIPT_HELP.split("events: ")[1] for name in EVENTS)
