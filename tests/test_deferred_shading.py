"""Deferred shading of glass (ShadeSurfaces' ``deferred``): the same image as shading per fragment."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.passes.shading import deferred, surfaces
from caustica.scene import (Camera, Diffuse, Glass, Mirror, PointLight, Scene, SceneObject, Transform,
                            procedural_environment)
from caustica.scene.shapes import box, sphere, torus

SIZE = (96, 72)


def crowded_scene(camera=None, environment_filter="bilinear") -> Scene:
    """Two glass objects of different IOR overlapping on screen, a diffuse box hiding part of one,
    a mirror and a floor: ids, keys and occlusion all matter. Bilinear environment lookups by
    default: the footprint filter's derivatives come from G-buffer neighbours in the deferred
    resolve and from the triangle's own lanes per fragment, so the two agree per sample only with
    one lookup per direction (the footprint case is test_footprint_filter_helps_deferred_and_forward_alike)."""
    objects = [
        SceneObject("ball", sphere(0.5, subdivisions=4), Glass(ior=1.5), Transform(position=[-0.3, 0.5, 0.0])),
        SceneObject("ring", torus(0.45, 0.15), Glass(ior=1.33, absorption_color=[0.8, 0.9, 1.0]),
                    Transform(position=[0.35, 0.55, -0.6], rotation=[60.0, 0.0, 0.0])),
        SceneObject("box", box((0.3, 0.3, 0.3)), Diffuse(color=[0.8, 0.3, 0.2]), Transform(position=[-0.1, 0.35, 0.8])),
        SceneObject("mirror", sphere(0.25, subdivisions=3), Mirror(), Transform(position=[0.9, 0.3, 0.3])),
    ]
    camera = camera or Camera(position=[0.0, 0.9, 3.0], look_at=[0.0, 0.45, 0.0], fov_y=45.0, size=SIZE)
    environment = procedural_environment("sky-checker")
    environment.filter = environment_filter
    return Scene(camera=camera, objects=objects, lights=[PointLight(position=[1.0, 4.0, 2.0], intensity=[15.0] * 3)],
                 environment=environment, name="crowded")


def overriding_shade_surfaces(monkeypatch, **overrides):
    """A render(renderer, scene, technique) with the given ShadeSurfaces attributes set on every run."""
    def render(renderer, scene, technique):
        with monkeypatch.context() as patch:
            original = surfaces.ShadeSurfaces.run

            def overridden(self, frame):
                for name, value in overrides.items():
                    setattr(self, name, value)
                original(self, frame)

            patch.setattr(surfaces.ShadeSurfaces, "run", overridden)
            return renderer.render(scene, technique)
    return render


@pytest.fixture()
def per_fragment(monkeypatch):
    """Render with every ShadeSurfaces shading per fragment (deferral off)."""
    return overriding_shade_surfaces(monkeypatch, deferred=())


def close_everywhere(deferred, forward, tolerance=2e-3, outliers=0.001):
    """Equal up to float rounding: the G-buffer rebuilds the position from the ray instead of
    interpolating it, so at most a few pixels on knife edges (TIR, silhouettes) may differ more."""
    difference = np.abs(deferred - forward).max(axis=-1)
    return float(np.mean(difference > tolerance)) <= outliers and float(np.mean(difference)) < 1e-4


@pytest.mark.parametrize("technique", ["depth-search", "image-space", "impostors"])
def test_deferred_glass_matches_per_fragment_shading(renderer, per_fragment, technique):
    scene = crowded_scene()
    deferred = renderer.render(scene, technique)
    forward = per_fragment(renderer, scene, technique)
    assert close_everywhere(deferred, forward)


def test_footprint_filter_helps_deferred_and_forward_alike(renderer, per_fragment):
    """With footprint-filtered environment lookups both paths come closer to the 64-spp image (bilinear
    lookups, the box filter) than one bilinear sample does. Measured at 96 x 72: bilinear 24.4 dB,
    deferred 25.1, per fragment 25.5 (they differ where a quad straddles two objects or two resolve
    stages)."""
    from caustica.metrics import psnr_linear

    truth = renderer.render(crowded_scene(), "depth-search", 64)
    point = psnr_linear(renderer.render(crowded_scene(), "depth-search"), truth)
    scene = crowded_scene(environment_filter="footprint")
    assert psnr_linear(renderer.render(scene, "depth-search"), truth) > point + 0.4
    assert psnr_linear(per_fragment(renderer, scene, "depth-search"), truth) > point + 0.4


def test_deferred_glass_seen_from_inside(renderer, per_fragment):
    """From inside a glass ball only back faces face the eye: the G-buffer keeps the normal facing the eye."""
    scene = crowded_scene(Camera(position=[-0.3, 0.5, 0.1], look_at=[-0.3, 0.5, -1.0], fov_y=60.0, size=SIZE))
    deferred = renderer.render(scene, "depth-search")
    assert close_everywhere(deferred, per_fragment(renderer, scene, "depth-search"))


def test_background_after_a_deferred_frame_is_whole(renderer):
    """A frame without objects right after a deferred one shows the whole environment (a clear of
    the G-buffer between the background and the objects once lost part of it on llvmpipe)."""
    scene = crowded_scene()
    renderer.render(scene, "depth-search")
    scene.objects = []
    image = renderer.render(scene, "depth-search")
    assert np.all(image.sum(axis=-1) > 0.0)
    np.testing.assert_array_equal(image, renderer.render(scene, "env-map"))


def test_deferred_runs_only_where_it_is_asked_for():
    assert surfaces.ShadeSurfaces("passes/shading/depth_search.frag", deferred=("glass",)).deferred == ("glass",)
    assert surfaces.ShadeSurfaces().deferred == ()
    with pytest.raises(ValueError, match="shared vertex stage"):
        surfaces.ShadeSurfaces("passes/shading/depth_search.frag", vertex="passes/shading/image_space.vert", deferred=("glass",))


def test_shade_options_declare_and_check_the_options():
    """ShadeSurfaces' arguments are ShadeOptions' fields (positional in order, or by name, or over an
    options object), checked alike; each is an attribute read and written through."""
    positional = surfaces.ShadeSurfaces("passes/shading/depth_search.frag", {"A": 1}, None, ("back_surface",), None,
                                        deferred=("glass",))
    named = surfaces.ShadeSurfaces(options=surfaces.ShadeOptions("passes/shading/depth_search.frag", {"A": 1}),
                                   deferred=("glass",))
    assert positional.options == named.options
    assert named.fragment == "passes/shading/depth_search.frag" and named.inputs == ("back_surface",)
    named.deferred = ("glass", "mirror")  # techniques set some after construction (impostors)
    assert named.options.deferred == ("glass", "mirror") and positional.deferred == ("glass",)
    assert surfaces.ShadeSurfaces(objects=["ball"]).objects == frozenset({"ball"})
    with pytest.raises(ValueError, match="at most 7 input channels"):
        surfaces.ShadeOptions(inputs=tuple(f"c{i}" for i in range(8)))
    with pytest.raises(ValueError, match="a free input unit"):
        surfaces.ShadeSurfaces(inputs=tuple(f"c{i}" for i in range(7)), deferred=("glass",))
    with pytest.raises(ValueError, match="two free input units"):  # the refine flags would take shadow map 0's unit
        surfaces.ShadeSurfaces(inputs=tuple(f"c{i}" for i in range(6)), deferred=("glass",), staged=("glass",))
    assert surfaces.ShadeSurfaces(inputs=tuple(f"c{i}" for i in range(5)), deferred=("glass",), staged=("glass",)).staged == ("glass",)
    with pytest.raises(ValueError, match="captures_front_surface needs"):
        surfaces.ShadeSurfaces("passes/shading/depth_search.frag", captures_front_surface=True, deferred=("glass",))
    shade = surfaces.ShadeSurfaces(inputs=("front_surface", "back_surface"), deferred=("glass",),
                                   captures_front_surface=True, background=False)
    assert shade.reads == ("light_samples", "shadow_maps", "back_surface", "color", "exit_direction", "depth")
    assert [c.name for c in shade.writes][-1] == "front_surface"


def test_too_many_glass_objects_are_shaded_per_fragment(renderer, per_fragment, monkeypatch):
    """Past MAX_DEFERRED glass objects (G-buffer ids) a run shades every object per fragment: the image
    is the per-fragment one, bit for bit."""
    monkeypatch.setattr(deferred, "MAX_DEFERRED", 1)  # the crowded scene has two glass objects
    scene = crowded_scene()
    np.testing.assert_array_equal(renderer.render(scene, "depth-search"), per_fragment(renderer, scene, "depth-search"))


@pytest.mark.parametrize("inside", [False, True])
def test_front_surface_from_the_gbuffer_equals_its_own_pass(monkeypatch, inside):
    """depth-search's front-surface buffer comes from the glass G-buffer draw (glass drawn first, a
    box in front of a ball): it equals RefractorSurfaces' separate front pass (per-object draws that
    one), and the image is unchanged. From inside the ball (back faces not culled) the run draws the
    separate pass itself."""
    from caustica.renderer import Renderer
    from caustica.techniques.raster import read_rgba

    camera = Camera(position=[-0.3, 0.5, 0.1], look_at=[-0.3, 0.5, -1.0], fov_y=60.0, size=SIZE) if inside else None
    scene = crowded_scene(camera)
    drawn_apart = []
    original = surfaces.refractor_surfaces
    monkeypatch.setattr(surfaces, "refractor_surfaces",
                        lambda frame, face, *rest: drawn_apart.append(face) or original(frame, face, *rest))
    renderer = Renderer(keep_channels=True)
    fused = renderer.render(scene, "depth-search")
    fused_front = read_rgba(renderer.channels["front_surface"])
    assert drawn_apart == (["back", "front"] if inside else ["back"])
    separate = renderer.render(scene, "per-object")  # depth-search for every object, its own front pass
    separate_front = read_rgba(renderer.channels["front_surface"])
    assert (fused_front[..., 3] > 0).sum() > 500
    np.testing.assert_array_equal(fused_front, separate_front)
    np.testing.assert_array_equal(fused, separate)


@pytest.fixture()
def one_stage(monkeypatch):
    """Render with every ShadeSurfaces resolving in one stage (``staged`` off)."""
    return overriding_shade_surfaces(monkeypatch, staged=())


@pytest.mark.parametrize("scene_name", ["ior-0.8 ball", "crowded"])
def test_staged_resolve_equals_one_stage(renderer, one_stage, monkeypatch, scene_name):
    """depth-search's silhouette search runs in a second resolve stage, at the pixels alone whose
    back-face iteration left the silhouette: the image is the one-stage image bit for bit. The IOR
    0.8 ball exits through its front faces in a ring (the search's case); the crowded scene has two
    staged objects and occlusion."""
    if scene_name == "crowded":
        scene = crowded_scene()
    else:
        camera = Camera(position=[0.0, 0.0, 4.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=SIZE)
        scene = Scene(camera=camera, objects=[SceneObject("ball", sphere(1.0, 5), Glass(ior=0.8))],
                      environment=procedural_environment("sky-checker"))
        scene.environment.filter = "bilinear"  # bit for bit: see test_staged_resolve_with_footprint_filter
    flags = []
    original = deferred.resolve_second_stage

    def reading_flags(frame, shade, staged, refine, *rest):
        flags.append(np.frombuffer(refine.read(), np.float32))
        return original(frame, shade, staged, refine, *rest)

    monkeypatch.setattr(deferred, "resolve_second_stage", reading_flags)
    staged = renderer.render(scene, "depth-search")
    assert len(flags) == 1
    keys, counts = np.unique(flags[0], return_counts=True)
    assert set(keys) <= {0.0, 1 / 256, 2 / 256}, keys  # a staged object's key, or nothing
    # 220 of 6912 pixels for the ball (its front-exit ring), 4 for the crowded scene (llvmpipe).
    assert counts[keys > 0].sum() >= (100 if scene_name == "ior-0.8 ball" else 1), (keys, counts)
    np.testing.assert_array_equal(staged, one_stage(renderer, scene, "depth-search"))


def test_staged_resolve_with_footprint_filter(renderer, one_stage):
    """With footprint-filtered lookups a pixel resolved in the first stage next to one left for the
    second takes its neighbour's first-stage direction as the footprint: a few pixels on the seam
    differ from the one-stage image (measured: 15 of 6912, 65.9 dB)."""
    from caustica.metrics import psnr_linear

    camera = Camera(position=[0.0, 0.0, 4.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=SIZE)
    scene = Scene(camera=camera, objects=[SceneObject("ball", sphere(1.0, 5), Glass(ior=0.8))],
                  environment=procedural_environment("sky-checker"))
    staged, single = renderer.render(scene, "depth-search"), one_stage(renderer, scene, "depth-search")
    assert psnr_linear(staged, single) > 50.0
    assert np.mean(np.abs(staged - single).max(axis=-1) > 0) < 0.005
