"""Memory that must not grow with new scenes, new Renderers or forks (issue 17, items 5 and 6).

A process that reloads its scene every frame, makes a Renderer per job, or forks workers after
it rendered keeps a bounded set of GL objects and pool entries; a forked child renders the
parent's image on a fresh context instead of hanging.
"""
from __future__ import annotations

import gc
import multiprocessing
import queue

import numpy as np
import pytest

from caustica.errors import CausticaError, GLUnavailableError, RendererClosedError
from caustica.renderer import Renderer
from caustica.scene.io import load_scene
from caustica.scene.presets import pool_scene

SIZE = (32, 32)
FORK_TIMEOUT_S = 120


def gl_or_skip() -> None:
    """Skip where no OpenGL 4.3 context can be made."""
    from caustica.gpu.context import shared_context

    try:
        shared_context()
    except GLUnavailableError as exc:
        pytest.skip(str(exc))


def footprint(renderer: Renderer) -> dict:
    """The device's pool and cache counts and the GL names alive in the context."""
    from caustica.gpu.census import live_gl_names

    counts = dict(renderer.device.counts())
    counts.pop("free_bytes")
    counts["gl_names"] = live_gl_names(renderer.device.ctx)["total"]
    return counts


def render_both(renderer: Renderer, scene) -> None:
    renderer.render(scene, "env-map")
    renderer.render(scene, "caustic-mapping", map_size=64)


def test_scene_reloads_keep_every_cache_bounded():
    """20 reloads of a preset (a new scene, environment image and meshes each time) leave the same
    counts as after the warm-up: textures keyed by content, pools bounded. A cache that grew by one
    entry in ten reloads would differ."""
    from caustica.gpu.device import CACHE_ENTRIES, ENVIRONMENT_TEXTURES
    from caustica.gpu.targets import FRAMEBUFFERS

    gl_or_skip()
    gc.collect()  # GL objects that earlier tests dropped go now (released at the next frame), not mid-count
    with Renderer(SIZE) as renderer:
        for _ in range(6):  # two frames a reload: past the pools' IDLE_FRAMES
            render_both(renderer, load_scene("caustics-pool"))
        warm = footprint(renderer)
        for _ in range(14):  # 28 frames: three of the pools' idle periods
            render_both(renderer, load_scene("caustics-pool"))
        after = footprint(renderer)
    assert after == warm
    assert after["environments"] == 1 <= ENVIRONMENT_TEXTURES
    assert after["cached"] <= CACHE_ENTRIES and after["framebuffers"] <= FRAMEBUFFERS
    assert after["lent_textures"] == 0


def test_animated_scene_meshes_released_after_idle_frames():
    """caustics-pool animated makes a new water mesh each frame: the meshes of frames more than
    IDLE_FRAMES ago go, so the mesh count and GL names stop growing."""
    from caustica.gpu.meshes import IDLE_FRAMES

    gl_or_skip()
    with Renderer(SIZE) as renderer:
        seen = []
        for frame in range(IDLE_FRAMES + 8):
            renderer.render(pool_scene(0.05 * frame), "env-map")
            seen.append(footprint(renderer))
        distinct = len(pool_scene(0.0).objects) - 3  # the four walls share one box mesh
        assert seen[-1]["meshes"] <= distinct + IDLE_FRAMES + 1
        assert seen[-1] == seen[-3]


def test_closed_renderers_leave_no_gl_objects():
    """A new Renderer per iteration, closed: the GL names alive do not grow; one dropped unclosed is
    released at the end of the next frame any Renderer draws."""
    from caustica.gpu.census import live_gl_names
    from caustica.gpu.context import shared_context

    gl_or_skip()
    ctx = shared_context()
    scene = load_scene("glass-sphere")
    gc.collect()  # what earlier tests dropped is released at the end of the next frame
    totals = []
    for _ in range(6):
        with Renderer(SIZE) as renderer:
            renderer.render(scene, "env-map")
        totals.append(live_gl_names(ctx)["total"])
    assert totals[-1] == totals[1]
    for _ in range(3):
        Renderer(SIZE).render(scene, "env-map")  # dropped without close
        gc.collect()
    with Renderer(SIZE) as renderer:
        renderer.render(scene, "env-map")
    assert live_gl_names(ctx)["total"] <= totals[-1]


def test_closed_renderer_raises_typed_error():
    gl_or_skip()
    scene = load_scene("glass-sphere")
    with Renderer(SIZE) as renderer:
        renderer.render(scene, "env-map")
    assert renderer.closed
    renderer.close()  # idempotent
    with pytest.raises(RendererClosedError) as err:
        renderer.render(scene, "env-map")
    assert isinstance(err.value, CausticaError) and "closed" in str(err.value)
    with pytest.raises(RendererClosedError):
        renderer.device
    with pytest.raises(RendererClosedError):
        with renderer:
            pass


def test_close_leaves_a_callers_device_alone():
    from caustica.gpu.device import GpuDevice

    gl_or_skip()
    device = GpuDevice()
    scene = load_scene("glass-sphere")
    with Renderer(SIZE, device=device) as renderer:
        first = renderer.render(scene, "env-map")
    with Renderer(SIZE, device=device) as renderer:
        assert np.array_equal(renderer.render(scene, "env-map"), first)
    device.release()


def test_stale_framebuffer_names_are_not_reused():
    """A cached framebuffer keyed by GL names must not draw into a texture released since, when a
    new texture gets the same name."""
    from caustica.gpu.device import GpuDevice

    gl_or_skip()
    device = GpuDevice()
    pool = device.targets
    old = device.ctx.texture((4, 4), 4)
    pool.framebuffer([old])
    name = old.glo
    old.release()
    new = device.ctx.texture((4, 4), 4)
    if new.glo == name:  # Mesa hands the freed name out again
        assert pool.framebuffer([new]).color_attachments[0] is new
    new.release()
    device.release()


def test_pool_releases_idle_targets():
    from caustica.gpu.device import GpuDevice

    gl_or_skip()
    device = GpuDevice()
    pool = device.targets
    pool.give_back(pool.texture((8, 8), "rgba32f"))
    assert pool.counts()["free_textures"] == 1
    for _ in range(pool.idle_frames + 1):
        pool.end_frame()
    assert pool.counts()["free_textures"] == 0
    device.release()


# Fork ---------------------------------------------------------------------------------------------

_PARENT: dict = {}


def _child(results, technique: str, scene_name: str) -> None:
    """Render with the parent's Renderer and a new one; then check that a fork of this child fails at once."""
    try:
        scene = load_scene(scene_name)
        inherited = _PARENT["renderer"].render(scene, technique)
        with Renderer(SIZE) as renderer:
            fresh = renderer.render(scene, technique)
        grandchild = multiprocessing.get_context("fork").Process(target=_grandchild, args=(results,))
        grandchild.start()
        grandchild.join(FORK_TIMEOUT_S)
        results.put(("images", inherited, fresh))
    except BaseException as exc:  # reported to the parent, which fails the test
        results.put(("error", repr(exc), None))


def _grandchild(results) -> None:
    try:
        Renderer(SIZE).render(load_scene("glass-sphere"), "env-map")
        results.put(("grandchild", "rendered", None))
    except GLUnavailableError as exc:
        results.put(("grandchild", str(exc), None))


@pytest.mark.parametrize("technique, scene_name", [("caustic-mapping", "caustics-point")])
def test_forked_child_renders_the_parents_image(technique, scene_name):
    """A worker forked after the parent rendered draws the same image (on a fresh EGL display)
    within the timeout; a fork of that worker raises GLUnavailableError naming 'spawn'."""
    gl_or_skip()
    renderer = _PARENT["renderer"] = Renderer(SIZE)
    expected = renderer.render(load_scene(scene_name), technique)
    context = multiprocessing.get_context("fork")
    results = context.Queue()
    child = context.Process(target=_child, args=(results, technique, scene_name))
    child.start()
    messages = {}
    try:
        for _ in range(2):
            kind, a, b = results.get(timeout=FORK_TIMEOUT_S)
            messages[kind] = (a, b)
    except queue.Empty:
        pass
    finally:
        child.join(10)
        if child.is_alive():
            child.kill()
            child.join()
    assert "error" not in messages, messages.get("error")
    assert "images" in messages, f"the forked child gave no image within {FORK_TIMEOUT_S} s (hung)"
    inherited, fresh = messages["images"]
    assert np.array_equal(inherited, expected) and np.array_equal(fresh, expected)
    grandchild = messages.get("grandchild", ("no answer", None))[0]
    assert grandchild == "rendered" or "'spawn'" in grandchild
    assert child.exitcode == 0
    assert np.array_equal(renderer.render(load_scene(scene_name), technique), expected)  # the parent still renders
    renderer.close()


def test_prepared_ray_geometry_of_animated_meshes_stays_under_its_byte_bound():
    """d_N of a new water surface every reload (image-space on the animated pool) keeps at most
    _GEOMETRY_CACHE_BYTES of Embree's prepared float64 triangles: 32 of them held 290 MB (the soak's
    step between frames 5000 and 7000, where the d_N disk cache was cold). The newest stays cached."""
    from caustica.raytrace import embree_scene
    from caustica.raytrace.paths import distance_along_negative_normal
    from caustica.scene.shapes import water_heightfield

    embree_scene._GEOMETRY_CACHE.clear()
    for step in range(12):
        mesh = water_heightfield((4.0, 4.0), resolution=160, amplitude=0.08, waves=6, seed=3, time=0.1 * step)
        distance_along_negative_normal(mesh)
        kept = sum(g.nbytes for g in embree_scene._GEOMETRY_CACHE.values())
        assert kept <= embree_scene._GEOMETRY_CACHE_BYTES
        assert any(key[0] == mesh.content_hash() for key in embree_scene._GEOMETRY_CACHE)
    assert 1 < len(embree_scene._GEOMETRY_CACHE) < 12
