"""The interactive viewer under Xvfb, driven by scripts of input events.

Viewer sessions run in child processes: a GLX window and the suite's headless
EGL context must not meet in one process. The child pickles the scene exactly
as its view saw it; this process renders that scene headless and compares.
"""
from __future__ import annotations

import json
import os
import pickle
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import caustica
from caustica.images import linear_to_srgb, read_image
from caustica.scene import Camera

ROOT = Path(__file__).resolve().parents[1]


def _have_viewer_packages() -> str | None:
    for module in ("glfw", "imgui_bundle", "OpenGL"):
        try:
            __import__(module)
        except ImportError:
            return f"{module} is not installed: pip install 'caustica[viewer]'"
    return None


@pytest.fixture(scope="module")
def display():
    """A display for the viewer: $DISPLAY, or an Xvfb server started here (skipped when neither exists)."""
    missing = _have_viewer_packages()
    if missing:
        pytest.skip(missing)
    if os.environ.get("DISPLAY"):
        yield os.environ["DISPLAY"]
        return
    if not shutil.which("Xvfb"):
        pytest.skip("no DISPLAY and Xvfb is not installed: apt-get install -y xvfb")
    number = 90 + os.getpid() % 500
    server = subprocess.Popen(["Xvfb", f":{number}", "-screen", "0", "1600x1000x24", "-nolisten", "tcp"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 10
    while not Path(f"/tmp/.X11-unix/X{number}").exists() and time.time() < deadline:
        time.sleep(0.1)
    if server.poll() is not None:
        pytest.skip(f"Xvfb :{number} did not start")
    yield f":{number}"
    server.terminate()
    server.wait(10)


def run_child(display: str, code: str, tmp_path: Path, timeout: int = 300) -> dict:
    """Run ``code`` (which fills ``result``) in a child process on ``display``; return ``result``."""
    script = ("import json, pickle, sys\nimport caustica\nfrom caustica.viewer import Viewer\nresult = {}\n"
              + code + f"\nopen({str(tmp_path / 'result.json')!r}, 'w').write(json.dumps(result))\n")
    env = {**os.environ, "DISPLAY": display}
    done = subprocess.run([sys.executable, "-c", script], check=False, cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=timeout)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads((tmp_path / "result.json").read_text())


def headless(scene_pickle: Path, technique: str, **params) -> np.ndarray:
    scene = pickle.loads(scene_pickle.read_bytes())
    return caustica.Renderer(scene.camera.size).render(scene, technique, **params)


def srgb8(image: np.ndarray) -> np.ndarray:
    return np.round(linear_to_srgb(np.clip(image, 0.0, 1.0)) * 255.0).astype(np.int16)


SESSION = """
scene = caustica.load_scene("caustic-sphere")
viewer = Viewer(scene, "env-map", size=(192, 160), fixed_step=True)
start = viewer.orbit.camera((192, 160)).position.tolist()
viewer.run(frames=3, script=[
    ("orbit", 40, -15),
    ("technique", "depth-search"),
    ("material", "ball", "ior", 1.33),
    ("param", "iterations", 3),
    ("inspect", "back_surface"),
    ("wait", 2),
])
result["inspecting"] = viewer.inspect
inspect_window = viewer.grab_window()
viewer.apply(("inspect", None))
viewer.apply(("panel", False))
viewer.apply(("overlay", False))
viewer.run(frames=viewer.frame_index + 2)
view_window = viewer.grab_window()
viewer.screenshot("shot.png")
viewer.screenshot("shot.exr")
open("scene.pkl", "wb").write(pickle.dumps(viewer.scene_view()))
import numpy as np
np.save("view_window.npy", view_window)
result.update(start=start, position=viewer.camera().position.tolist(), technique=viewer.technique,
              params=viewer.params, ior=viewer.scene.objects[0].material.ior, error=viewer.error,
              window=list(view_window.shape), inspect_differs=bool(np.abs(inspect_window[:, :192].astype(int)
                                                                          - view_window[:, :192]).mean() > 5),
              frames=viewer.frame_index)
report = viewer.close()
result.update(gl_error=report.gl_error, live=report.live_objects, window_gone=viewer.window is None,
              earlier=report.earlier_errors)
"""


def test_scripted_session_matches_headless_render(display, tmp_path):
    """Orbit, switch technique, change the IOR, open the inspector, screenshot: the frame equals a headless render."""
    result = run_child(display, SESSION, tmp_path)
    # The events took effect.
    assert result["error"] is None
    assert result["technique"] == "depth-search" and result["params"] == {"iterations": 3}
    assert result["ior"] == pytest.approx(1.33)
    assert np.linalg.norm(np.subtract(result["start"], result["position"])) > 0.5  # the orbit moved the eye
    assert result["inspecting"] == "back_surface" and result["inspect_differs"]
    # The screenshot (PNG and EXR) is the headless render of the same scene and camera.
    reference = headless(tmp_path / "scene.pkl", "depth-search", iterations=3)
    assert reference.shape == (160, 192, 3)
    shot = read_image(tmp_path / "shot.exr")
    assert np.abs(shot - reference).max() < 1e-3
    png = np.asarray(__import__("PIL.Image", fromlist=["Image"]).open(tmp_path / "shot.png").convert("RGB"), np.int16)
    assert np.abs(png - srgb8(reference)).max() <= 1
    # What the window showed (panel and overlay hidden: the view fills it) is the same image, drawn on screen.
    window = np.load(tmp_path / "view_window.npy").astype(np.int16)
    assert tuple(result["window"]) == (160, 192, 3)
    assert np.abs(window - srgb8(reference)).max() <= 1
    # Closing released every GL object and the window without a GL error.
    assert result["gl_error"] == "GL_NO_ERROR", result["earlier"]
    assert result["live"] == {}
    assert result["window_gone"]


def test_side_by_side_difference_of_a_technique_with_itself_is_black(display, tmp_path):
    """Two views side by side, their difference; with the overlay on, each half has a caption box at its
    lower left (its technique's name)."""
    result = run_child(display, """
scene = caustica.load_scene("glass-sphere")
viewer = Viewer(scene, "env-map", size=(128, 128), panel=False, overlay=False)
viewer.run(frames=2, script=[("side_by_side", "image-space")])
both = viewer.grab_window()
result["both"] = list(both.shape)
result["halves_differ"] = float(abs(both[:, :128].astype(int) - both[:, 128:]).mean())
viewer.apply(("overlay", True))
viewer.run(frames=viewer.frame_index + 4)
captioned = viewer.grab_window()
result["rects"], result["captions"] = viewer.caption_rects, viewer.state.view_captions(viewer.main, viewer.other)
result["changed"] = [float(abs(captioned[128 - y - h:128 - y, x:x + w].astype(int) - both[128 - y - h:128 - y, x:x + w])
                           .mean()) for x, y, w, h in viewer.caption_rects]
viewer.apply(("overlay", False))
viewer.apply(("side_by_side", "env-map", True))
viewer.run(frames=viewer.frame_index + 2)
result["difference_max"] = int(viewer.grab_window()[:, :128].max())
report = viewer.close()
result["live"] = report.live_objects
""", tmp_path)
    assert result["both"] == [128, 256, 3]  # the window widened to hold two views
    assert result["halves_differ"] > 0.5  # env-map and image-space differ on the sphere
    assert result["captions"] == ["env-map", "image-space"]
    (x0, y0, w0, _), (x1, y1, _, _) = result["rects"]
    assert x0 < 128 and x0 + w0 <= 128 and x1 >= 128 and y0 < 20 and y1 < 20  # one per half, at the bottom
    assert all(change > 5.0 for change in result["changed"])  # the boxes are drawn over the views
    assert result["difference_max"] <= 1  # |a - a| = 0
    assert result["live"] == {}


def test_cli_view_frames_and_screenshot(display, tmp_path):
    env = {**os.environ, "DISPLAY": display}
    done = subprocess.run([sys.executable, "-m", "caustica.cli", "view", "glass-sphere", "--frames", "3", "--size",
                           "96x96", "--screenshot", str(tmp_path / "view.png"), "--window-screenshot",
                           str(tmp_path / "window.png")], env=env, check=False, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "3 frames" in done.stdout and "ms per frame" in done.stdout
    reference = caustica.Renderer((96, 96)).render(caustica.load_scene("glass-sphere"), "auto")  # the default
    from PIL import Image

    shot = np.asarray(Image.open(tmp_path / "view.png").convert("RGB"), np.int16)
    assert np.abs(shot - srgb8(reference)).max() <= 1
    assert Image.open(tmp_path / "window.png").size[0] > 96  # the panel beside the view


def test_cli_view_without_display_says_to_render_headless():
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    done = subprocess.run([sys.executable, "-m", "caustica.cli", "view", "glass-sphere"], env=env, check=False,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert done.stderr.strip() == ("caustica: no display found (DISPLAY is not set); "
                                   "use 'caustica render' for headless images")


def test_cli_view_rejects_a_bad_script(tmp_path, display):
    (tmp_path / "bad.json").write_text("{not json")
    env = {**os.environ, "DISPLAY": display}
    done = subprocess.run([sys.executable, "-m", "caustica.cli", "view", "glass-sphere", "--script",
                           str(tmp_path / "bad.json")], env=env, check=False, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "is not JSON" in done.stderr


def test_orbit_camera_starts_at_the_scene_camera_and_orbits_about_the_target():
    from caustica.viewer.orbit import OrbitCamera

    home = Camera(position=[1.0, 2.0, 4.0], look_at=[0.0, 0.5, 0.0], fov_y=35.0, size=(320, 200))
    orbit = OrbitCamera(home)
    np.testing.assert_allclose(orbit.camera(home.size).position, home.position, atol=1e-12)
    distance = np.linalg.norm(home.position - home.look_at)
    orbit.orbit(100, 40)
    assert np.linalg.norm(orbit.position - orbit.target) == pytest.approx(distance)
    assert not np.allclose(orbit.position, home.position)
    orbit.zoom(1)
    assert orbit.distance == pytest.approx(0.9 * distance)
    orbit.pan(10, 0, 200)
    assert not np.allclose(orbit.target, home.look_at)
    orbit.frame(np.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]]))
    np.testing.assert_allclose(orbit.target, 0.0, atol=1e-12)
    orbit.reset()
    np.testing.assert_allclose(orbit.position, home.position, atol=1e-12)
    orbit.orbit(0, 10_000)  # never over the pole
    assert orbit.pitch <= 89.0


def test_parameter_controls_come_from_each_techniques_validation():
    from caustica.techniques import get_technique
    from caustica.viewer.params import param_specs

    specs = {s.name: s for s in param_specs(get_technique("image-space"))}
    assert specs["tir_mode"].kind == "choice" and set(specs["tir_mode"].choices) == {"keep-t1", "clamp", "reflect"}
    assert specs["use_dn"].kind == "bool"
    assert (specs["shadow_map_size"].low, specs["shadow_map_size"].high) == (16, 8192)
    depth = {s.name: s for s in param_specs(get_technique("depth-search"))}
    assert depth["search_steps"].kind == "int" and depth["search_steps"].clamp(99) == 16
    assert depth["search_start"].kind == "float"


def test_animated_presets_are_found_by_the_generic_hook():
    from caustica.scene.presets import PRESETS
    from caustica.viewer.app import animated_variant

    assert animated_variant("glass-sphere") is None
    if "caustics-pool" in PRESETS:
        scene_at = animated_variant("caustics-pool")
        assert scene_at is not None
        a, b = scene_at(0.0), scene_at(0.5)
        assert a.objects[0].mesh.content_hash() != b.objects[0].mesh.content_hash()


def test_show_returns_an_image_without_widgets():
    """``caustica.show``: a PIL image (displayed inline by Jupyter) when ipywidgets is absent or not asked for."""
    image = caustica.show("glass-sphere", size=(64, 48), widgets=False)
    assert image.size == (64, 48)
    reference = caustica.Renderer((64, 48)).render(caustica.load_scene("glass-sphere"), "auto")  # the default
    assert np.abs(np.asarray(image, np.int16) - srgb8(reference)).max() <= 1


def test_object_technique_switches_to_per_object(display, tmp_path):
    """Choosing a glass object's technique in the panel shows that object with it: the headless ``per-object`` render."""
    result = run_child(display, """
scene = caustica.load_scene("tvcg-fig11")
viewer = Viewer(scene, "depth-search", size=(160, 96), fixed_step=True)
viewer.run(frames=2, script=[("object_technique", "sphere-0", "env-map"), ("wait", 1)])
result.update(technique=viewer.technique, params=viewer.params, error=viewer.error,
              shown=[viewer.object_technique(o.name) for o in viewer.scene.objects_of("glass")])
viewer.apply(("object_technique", "floor", "env-map"))
result["floor_error"] = viewer.error
viewer.screenshot("shot.exr")
open("scene.pkl", "wb").write(pickle.dumps(viewer.scene_view()))
report = viewer.close()
result.update(gl_error=report.gl_error, live=report.live_objects)
""", tmp_path)
    assert result["error"] is None
    assert result["technique"] == "per-object"
    assert result["params"] == {"techniques": {"sphere-0": "env-map"}, "default": "depth-search"}
    assert result["shown"] == ["env-map", "depth-search", "depth-search"]
    assert "only glass objects" in result["floor_error"]
    reference = headless(tmp_path / "scene.pkl", "per-object", **result["params"])
    assert np.abs(read_image(tmp_path / "shot.exr") - reference).max() < 1e-3
    # The env-map sphere really differs from the depth-search render.
    assert np.abs(reference - headless(tmp_path / "scene.pkl", "depth-search")).max() > 0.1
    assert result["gl_error"] == "GL_NO_ERROR" and result["live"] == {}


UI_LAYER = """
import numpy as np
from caustica.viewer import ui_layer
scene = caustica.load_scene("glass-sphere")
viewer = Viewer(scene, "env-map", size=(160, 128), fixed_step=True, overlay=False)  # its fps text changes
ui_layer.REFRESH_S = 1e9  # no timed refresh: ImGui runs only after input
redraws = []
draw = viewer.ui.redraw
viewer.ui.redraw = lambda *args: (redraws.append(viewer.frame_index), draw(*args))
viewer.run(frames=20)
idle = viewer.grab_window()  # the panel copied from the retained layer
viewer.ui.touch()
viewer.run(frames=viewer.frame_index + 1)
fresh = viewer.grab_window()  # ImGui ran this frame; the whole layer blended over the window
result.update(redraws=redraws, panel_equal=bool(np.array_equal(idle[:, 160:], fresh[:, 160:])),
              view_equal=bool(np.array_equal(idle[:, :160], fresh[:, :160])),
              panel_drawn=float(idle[:, 160:].std()))
viewer.apply(("panel", False))
viewer.run(frames=viewer.frame_index + 2)
result["hidden_width"] = int(viewer.grab_window().shape[1])
report = viewer.close()
result.update(gl_error=report.gl_error, live=report.live_objects)
"""


def test_retained_ui_layer_runs_imgui_only_after_input_and_composites_the_same_window(display, tmp_path):
    """ImGui runs for a few frames after opening (and after input), then the cached layer is reused: the
    window it gives equals the one a fresh ImGui frame gives."""
    result = run_child(display, UI_LAYER, tmp_path)
    idle = [frame for frame in result["redraws"] if frame < 20]
    assert len(idle) <= 5 and max(idle) < 8  # the first frames only (SETTLE_FRAMES), none while idle
    assert 21 in result["redraws"]  # the touch made ImGui run again (frame 20 was the idle grab)
    assert result["panel_equal"] and result["view_equal"]
    assert result["panel_drawn"] > 10.0  # the panel is there, not a flat colour
    assert result["hidden_width"] == 160
    assert result["gl_error"] == "GL_NO_ERROR" and not any(result["live"].values())


AFTER_HEADLESS = """
from caustica.renderer import Renderer
scene = caustica.load_scene("glass-sphere")
result["headless_mean"] = float(Renderer((32, 32)).render(scene, "env-map").mean())  # the EGL context first
viewer = Viewer(scene, "env-map", size=(96, 80))
viewer.run(frames=3)
result["window"] = list(viewer.grab_window().shape)
report = viewer.close()
result.update(gl_error=report.gl_error, live=report.live_objects)
"""


def test_viewer_opens_after_a_headless_render_in_the_same_process(display, tmp_path):
    """A notebook renders headless, then opens the viewer: the window takes an EGL context too (a GLX one
    aborts the process with an X BadAccess error), draws, and closes cleanly."""
    result = run_child(display, AFTER_HEADLESS, tmp_path)
    assert result["headless_mean"] > 0.0
    assert result["window"][0] == 80 and result["window"][1] > 96
    assert result["gl_error"] == "GL_NO_ERROR" and not any(result["live"].values())


def test_per_object_techniques_take_their_own_parameters_in_the_viewer(display, tmp_path):
    """With objects on per-object, a technique's parameter (``depth-search.iterations``) is set from the
    panel's per-technique section and survives adding caustics; the view is the headless render."""
    result = run_child(display, """
scene = caustica.load_scene("tvcg-fig11")
viewer = Viewer(scene, "depth-search", size=(160, 96), fixed_step=True)
viewer.run(frames=2, script=[("object_technique", "sphere-0", "env-map"), ("param", "depth-search.iterations", 0),
                             ("param", "depth-search.iterationz", 1), ("wait", 1)])
result.update(error=viewer.error, params=viewer.params)
viewer.screenshot("shot.exr")
open("scene.pkl", "wb").write(pickle.dumps(viewer.scene_view()))
viewer.apply(("technique", "per-object+caustic-mapping"))
viewer.run(frames=viewer.frame_index + 1)
result.update(composed=viewer.params, composed_error=viewer.error)
report = viewer.close()
result.update(gl_error=report.gl_error, live=report.live_objects)
""", tmp_path)
    assert "iterationz" in result["error"]  # the bad name is refused and reported, the good one kept
    assert result["params"]["depth-search.iterations"] == 0
    reference = headless(tmp_path / "scene.pkl", "per-object", **result["params"])
    assert np.abs(read_image(tmp_path / "shot.exr") - reference).max() < 1e-3
    assert np.abs(reference - headless(tmp_path / "scene.pkl", "per-object",
                                       techniques=result["params"]["techniques"])).max() > 0.05
    assert result["composed"]["depth-search.iterations"] == 0 and result["composed_error"] is None
    # Closing after caustic-mapping leaves nothing either (compute dispatches unbind their program: run_compute).
    assert result["gl_error"] == "GL_NO_ERROR" and not any(result["live"].values())


FILMIC_SESSION = """
import numpy as np
scene = caustica.load_scene("caustic-sphere")
viewer = Viewer(scene, "auto", size=(192, 160), panel=False, overlay=False, fixed_step=True)
viewer.run(frames=2, script=[("exposure", 1.0), ("tonemap", "filmic"), ("wait", 1)])
np.save("window.npy", viewer.grab_window())
viewer.screenshot("shot.png")
viewer.screenshot("shot.exr")
open("scene.pkl", "wb").write(pickle.dumps(viewer.scene_view()))
result.update(tonemap=viewer.tonemap, exposure=viewer.exposure, error=viewer.error)
try:
    viewer.apply(("tonemap", "aces"))
except caustica.CausticaError as exc:
    result["refused"] = str(exc)
result["after_refusal"] = viewer.tonemap
report = viewer.close()
result.update(gl_error=report.gl_error, live=report.live_objects)
"""


def test_scripted_session_with_filmic_tonemap_matches_headless_png(display, tmp_path):
    """With ``("tonemap", "filmic")`` the window and the PNG screenshot are ``images.to_srgb8(headless render,
    tonemap="filmic")`` (the PNG ``caustica render --tonemap filmic`` writes), within one code; EXR stays linear."""
    from PIL import Image

    from caustica.images import to_srgb8

    result = run_child(display, FILMIC_SESSION, tmp_path)
    assert result["error"] is None and result["tonemap"] == "filmic" and result["exposure"] == 1.0
    assert result["refused"] == "unknown tonemap 'aces'; use one of clip, filmic"
    assert result["after_refusal"] == "filmic"
    reference = headless(tmp_path / "scene.pkl", "auto")
    assert np.abs(read_image(tmp_path / "shot.exr") - reference).max() < 1e-3
    expected = to_srgb8(reference, 1.0, "filmic").astype(np.int16)
    png = np.asarray(Image.open(tmp_path / "shot.png").convert("RGB"), np.int16)
    assert np.abs(png - expected).max() <= 1
    window = np.load(tmp_path / "window.npy").astype(np.int16)
    assert window.shape == (160, 192, 3)
    assert np.abs(window - expected).max() <= 1
    # The curve took effect: highlights clip would flatten to 255 keep distinct codes below it.
    clipped = to_srgb8(reference, 1.0, "clip")
    assert (clipped == 255).any(axis=2).mean() > 0.002
    assert (png == 255).any(axis=2).mean() < 0.2 * (clipped == 255).any(axis=2).mean()
    assert len(np.unique(png[(clipped == 255).all(axis=2)])) > 5
    assert result["gl_error"] == "GL_NO_ERROR" and result["live"] == {}


RAMP = """
import numpy as np
from caustica.images import to_srgb8
scene = caustica.load_scene("glass-sphere")
viewer = Viewer(scene, "env-map", size=(256, 128), panel=False, overlay=False)
viewer.run(frames=1)
width, height = 256, 128
ramp = np.linspace(0.0, 50.0, width * height, dtype=np.float32).reshape(height, width)
pixels = np.stack([ramp, ramp[::-1], np.sqrt(ramp * 50.0)], axis=2).astype(np.float32)  # texture row 0 = window bottom row
texture = viewer.ctx.texture((width, height), 3, pixels.tobytes(), dtype="f4")
worst = {}
for tonemap in ("clip", "filmic"):
    for exposure in (0.0, -2.5):
        viewer.display.draw(texture, (0, 0, width, height), "color", exposure, 1, tonemap=tonemap)
        shown = np.frombuffer(viewer.ctx.screen.read(viewport=(0, 0, width, height), components=3), np.uint8)
        shown = shown.reshape(height, width, 3).astype(np.int16)
        expected = to_srgb8(pixels, exposure, tonemap).astype(np.int16)
        worst[f"{tonemap} {exposure}"] = int(np.abs(shown - expected).max())
        worst[f"{tonemap} {exposure} white"] = float((shown[..., 0] == 255).mean())
texture.release()
result["worst"] = worst
report = viewer.close()
result.update(gl_error=report.gl_error, live=report.live_objects)
"""


def test_display_shader_filmic_curve_matches_images_filmic_on_a_ramp(display, tmp_path):
    """A 0..50 ramp texture drawn by the display shader and read back from the window: the GLSL filmic (and
    clip) curve gives ``images.to_srgb8``'s codes within one, at two exposures."""
    result = run_child(display, RAMP, tmp_path)
    worst = result["worst"]
    for tonemap in ("clip", "filmic"):
        for exposure in (0.0, -2.5):
            assert worst[f"{tonemap} {exposure}"] <= 1, worst
    # Red runs 0..50: clip is white from 1 on (98% of the ramp), filmic reaches code 255 only from ~70.
    assert worst["clip 0.0 white"] > 0.97 and worst["filmic 0.0 white"] == 0.0
    assert result["gl_error"] == "GL_NO_ERROR" and result["live"] == {}


def test_cli_view_tonemap_filmic_screenshot(display, tmp_path):
    from PIL import Image

    from caustica.images import to_srgb8

    env = {**os.environ, "DISPLAY": display}
    done = subprocess.run([sys.executable, "-m", "caustica.cli", "view", "caustic-sphere", "--frames", "2", "--size",
                           "96x80", "--exposure", "1", "--tonemap", "filmic", "--screenshot", str(tmp_path / "view.png")],
                          env=env, check=False, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    reference = caustica.Renderer((96, 80)).render(caustica.load_scene("caustic-sphere"), "auto")
    shot = np.asarray(Image.open(tmp_path / "view.png").convert("RGB"), np.int16)
    assert np.abs(shot - to_srgb8(reference, 1.0, "filmic").astype(np.int16)).max() <= 1


def test_cli_view_antialias_msaa_screenshot_is_the_renderers(display, tmp_path):
    """``caustica view --antialias msaa``: the view (its EXR screenshot) is Renderer.render's msaa image."""
    from caustica.images import read_image

    env = {**os.environ, "DISPLAY": display}
    done = subprocess.run([sys.executable, "-m", "caustica.cli", "view", "door-mirror", "-t", "plain", "--frames", "2",
                           "--size", "96x80", "--antialias", "msaa", "--screenshot", str(tmp_path / "view.exr")],
                          env=env, check=False, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    with caustica.Renderer((96, 80)) as renderer:
        scene = caustica.load_scene("door-mirror")
        reference = renderer.render(scene, "plain", antialias="msaa")
        assert np.abs(reference - renderer.render(scene, "plain")).max() > 0.05  # msaa changes the frame
    assert np.abs(read_image(tmp_path / "view.exr") - reference).max() < 1e-3


def test_cli_view_bad_tonemap_is_one_line():
    done = subprocess.run([sys.executable, "-m", "caustica.cli", "view", "glass-sphere", "--tonemap", "aces"],
                          check=False, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    err = done.stderr.strip()
    assert len(err.splitlines()) == 1 and "--tonemap" in err and "'aces'" in err and "clip" in err and "filmic" in err


def test_live_frames_honour_auto_budget(tmp_path, monkeypatch):
    """The viewer's frames resolve auto's budget through their renderer (no window needed: a headless device)."""
    from caustica.gpu.device import GpuDevice
    from caustica.viewer.frames import LiveRenderer

    monkeypatch.setenv("CAUSTICA_CACHE", str(tmp_path))
    scene = caustica.load_scene("caustic-sphere")
    camera = scene.camera.with_size(32, 24)
    device = GpuDevice()
    live = LiveRenderer(device)
    try:
        image = live.render("main", scene, camera, "auto", {"budget_ms": 1e5})
        assert image.color is not None and image.technique == "impostors+caustic-mapping"
        assert len(list((tmp_path / "costs").iterdir())) == 1  # high was measured and fitted
        with pytest.raises(caustica.TechniqueError, match="cheapest plan"):
            live.render("main", scene, camera, "auto", {"budget_ms": 0.001})
    finally:
        live.release()
        device.release()

