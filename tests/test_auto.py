"""``auto``: the plan per scene kind (docs/auto.md's table), its accuracy over depth-search, `caustica plan`."""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import caustica
from caustica import Renderer, TechniqueError
from caustica.planning.rules import plan
from caustica.scene import (Camera, Diffuse, Glass, Mirror, PointLight, Scene, SceneObject, Transform,
                            procedural_environment)
from caustica.scene.shapes import box, plane, sphere

DOCS = Path(__file__).resolve().parents[1] / "docs" / "auto.md"


def marble(name="marble", x=0.3):
    return SceneObject(name, sphere(0.45, 3), Glass(ior=1.45), Transform(position=[x, 0.55, -0.2]))


def table():
    return SceneObject("table", box((3.0, 0.1, 2.4)), Diffuse(color=[0.7, 0.5, 0.3]), Transform(position=[0, -0.05, 0]))


def mirror():
    return SceneObject("mirror", plane((0.8, 0.6)), Mirror(), Transform(position=[-0.8, 0.6, -0.6], rotation=[90, 0, 0]))


def dish():
    """A concave spherical mirror (curvature radius 1.5) facing the camera."""
    from caustica.scene.mesh import Mesh
    from caustica.scene.presets_per_vertex import curved_mirror

    return SceneObject("dish", Mesh(*curved_mirror(1.2, 1.0, -1.5, 12)), Mirror(),
                       Transform(position=[-0.6, 0.7, -0.8], rotation=[70, 0, 0]))


def cylinder():
    """A convex cylindrical mirror (radius 1, curved across, its axis vertical) facing the camera over the table."""
    from caustica.scene.mesh import Mesh
    from caustica.scene.presets_per_vertex import curved_mirror

    return SceneObject("cylinder", Mesh(*curved_mirror(1.2, 1.0, 1.0, 12, "cylinder")), Mirror(),
                       Transform(position=[-0.4, 0.6, -0.8], rotation=[90, 0, 0]))


def scene_of(objects, light=False, size=(96, 72)) -> Scene:
    lights = [PointLight(position=[-1.0, 3.0, 1.0], intensity=[8.0, 8.0, 8.0])] if light else []
    camera = Camera(position=[1.8, 1.4, 2.4], look_at=[0.2, 0.4, -0.2], fov_y=38.0, size=size)
    return Scene(camera=camera, objects=objects, lights=lights, environment=procedural_environment("sky-checker"))


KINDS = {  # docs/auto.md's "scene holds" column -> such a scene
    "glass alone": lambda: scene_of([marble()]),
    "two glass objects": lambda: scene_of([marble("a", -0.4), marble("b", 0.6)]),
    "glass and a diffuse floor, no light": lambda: scene_of([marble(), table()]),
    "glass, a diffuse floor and a light": lambda: scene_of([marble(), table()], light=True),
    "glass, a mirror, a diffuse floor and a light": lambda: scene_of([marble(), mirror(), table()], light=True),
    "a mirror alone": lambda: scene_of([mirror()]),
    "a mirror, a diffuse floor and a light": lambda: scene_of([mirror(), table()], light=True),
    "a concave mirror, a diffuse floor and a light": lambda: scene_of([dish(), table()], light=True),
    "a cylindrical mirror, a diffuse floor and a light": lambda: scene_of([cylinder(), table()], light=True),
    "a diffuse floor and a light": lambda: scene_of([table()], light=True),
    "glass of IOR 1 that absorbs nothing, a diffuse floor and a light": lambda: scene_of([clear_ball(), table()],
                                                                                           light=True),
    "nothing": lambda: scene_of([]),
}


def documented_rules() -> dict[str, str]:
    text = DOCS.read_text()
    block = text[text.index("<!-- plan-rules -->"):text.index("<!-- /plan-rules -->")]
    rows = re.findall(r"^\| ([^|]+?) \| ([^|]+?) \|$", block, flags=re.M)
    return {kind: technique for kind, technique in rows if kind not in ("scene holds", "---")}


def test_the_documented_table_covers_every_kind():
    assert set(documented_rules()) == set(KINDS)


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_auto_plans_the_documented_technique(kind):
    chosen = plan(KINDS[kind]())
    assert chosen.technique == documented_rules()[kind]


def test_auto_renders_the_plan_and_every_quality():
    scene = scene_of([marble(), table()], light=True, size=(48, 36))
    with Renderer() as renderer:
        auto = renderer.render(scene, "auto")
        chosen = plan(scene)
        assert np.array_equal(auto, renderer.render(scene, chosen.technique, **chosen.params))
        draft = renderer.render(scene, "auto", quality="draft")
        assert not np.array_equal(auto, draft)  # no internal bounces, smaller maps


def test_the_plans_parameters_reproduce_auto_with_its_light_maps():
    """Where auto bakes the environment's light, the plan says so (environment_bake), and the planned technique
    named with the plan's parameters renders auto's image; without them the diffuse pixels differ."""
    block = SceneObject("block", box((0.5, 0.5, 0.5)), Diffuse(color=[0.5, 0.5, 0.5]),
                        Transform(position=[-0.4, 0.25, 0]))
    scene = scene_of([marble(), table(), block], size=(48, 36))
    with Renderer() as renderer:
        auto = renderer.render(scene, "auto")
        chosen = renderer.last_plan
        assert chosen.params.get("environment_bake", 0) > 0 and chosen.params == plan(scene).params
        assert np.array_equal(auto, renderer.render(scene, chosen.technique, **chosen.params))
        unbaked = {k: v for k, v in chosen.params.items() if k != "environment_bake"}
        assert np.abs(auto - renderer.render(scene, chosen.technique, **unbaked)).max() > 0.01
        # auto's own environment_bake=0 takes it out of the plan as well.
        renderer.render(scene, "auto", environment_bake=0)
        assert "environment_bake" not in renderer.last_plan.params


def test_auto_sees_the_floor_through_glass_far_better_than_depth_search():
    """A glass ball over a table, lit by the environment alone (so the oracle, which has no caustics,
    is the whole truth): auto's glass pixels against exact. Measured on llvmpipe: auto 27.6 dB,
    depth-search 21.7 dB, env-map 10.2 dB."""
    scene = scene_of([marble(), table()])
    with Renderer() as renderer:
        reference = renderer.render(scene, "exact", spp=4)
        glass = renderer.exit_directions(scene, "depth-search")[1]
        assert glass.sum() > 500

        def psnr(technique):
            image = renderer.render(scene, technique, spp=4)
            return 10 * np.log10(reference[glass].max() ** 2 / ((image - reference) ** 2)[glass].mean())

        assert psnr("auto") > psnr("depth-search") + 4.0


def test_plan_names_each_object_and_why():
    scene = scene_of([marble(), mirror(), table()], light=True)
    chosen = caustica.plan(scene, "high", frame_size=(512, 384))  # a frame that takes the quality's whole map
    assert chosen.technique == "impostors+caustic-mapping"
    assert chosen.params["internal_bounces"] == 4 and chosen.params["caustic-mapping.map_size"] == 1024
    by_name = {entry.object: entry for entry in chosen.objects}
    assert set(by_name) == {"marble", "mirror", "table"}
    assert "impostors" in by_name["marble"].reason and "internal bounces" in by_name["marble"].reason
    assert "reflections" in by_name["mirror"].reason
    assert "caustics" in by_name["table"].reason and by_name["table"].handled_by == "impostors + caustic-mapping"
    assert json.loads(chosen.to_json())["technique"] == "impostors+caustic-mapping"


def test_plan_and_explain_commands(tmp_path, capsys):
    from caustica.cli import main

    assert main(["plan", "caustic-sphere"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("technique: impostors+caustic-mapping") and "ball (glass)" in out and "floor (diffuse)" in out
    assert main(["plan", "glass-sphere", "--json", "--quality", "draft"]) == 0
    assert json.loads(capsys.readouterr().out)["params"]["internal_bounces"] == 0
    image = tmp_path / "a.png"
    assert main(["render", "glass-sphere", "-o", str(image), "--size", "32x24", "--frames", "1", "--explain"]) == 0
    out = capsys.readouterr().out
    assert "technique: depth-search" in out and "auto" in out and image.is_file()


def test_bad_quality_is_one_line():
    from caustica.cli import main

    with pytest.raises(TechniqueError, match="quality"):
        plan(scene_of([marble()]), "best")
    with pytest.raises(TechniqueError, match="quality"):
        Renderer((8, 8)).render(scene_of([marble()]), "auto", quality="best")
    assert main(["plan", "glass-sphere", "--quality", "best"]) == 2
    assert main(["render", "glass-sphere", "-o", "/tmp/x.png", "-t", "env-map", "--quality", "high"]) == 2


def test_auto_is_the_default_everywhere():
    from caustica.cli import build_parser

    parser = build_parser()
    assert parser.parse_args(["render", "s", "-o", "x.png"]).technique == "auto"
    assert parser.parse_args(["view", "s"]).technique == "auto"
    assert parser.parse_args(["compare", "s"]).techniques == ["auto", "exact"]
    makefile = (Path(__file__).resolve().parents[1] / "Makefile").read_text()
    demo = next(line for line in makefile.splitlines() if "caustica render" in line)
    assert "--technique" not in demo and "-t " not in demo


def test_other_parameters_go_to_the_planned_technique():
    scene = scene_of([marble()], size=(32, 24))
    with Renderer() as renderer:
        assert np.array_equal(renderer.render(scene, "auto", internal_bounces=0),
                              renderer.render(scene, "depth-search", internal_bounces=0, shadow_map_size=1024,
                                              convex_exits=True))
        with pytest.raises(TechniqueError, match="auto planned 'depth-search'.*shadow_map_sise.*shadow_map_size"):
            renderer.render(scene, "auto", shadow_map_sise=64)


@pytest.mark.parametrize("ior", [1.01, 1.33, 1.5])
def test_the_caustic_under_glass_is_seen_through_it(ior):
    """A flat glass slab over a floor under a point light (caustics-pool's water, simplified): the
    light the slab passes makes the floor under it as bright as with no slab, less Fresnel at the
    two interfaces the light crosses and the two the view crosses, about (1 - R0)^4. The impostor
    textures must carry the caustic: before they did, the floor under the slab was its shadow
    (measured: ratio 0.09 at IOR 1.01; then 1.006, 0.918 at 1.33, 0.849 at 1.5). The light that enters the
    top near an edge reflects totally off the side wall and lands about 0.2 inside the slab's outline (a
    band twice as bright, in Embree's photons and in caustic mapping's since exit_reflections): the closed
    form holds where the floor lies farther from the edges, |x|, |z| < 0.7 (measured there, at 128 x 106
    for as many pixels as before: 1.001, 0.900, 0.832 against 1.000, 0.922, 0.849)."""
    from scipy.ndimage import binary_erosion

    def slab_scene(with_slab):
        objects = [SceneObject("floor", plane((4.0, 4.0)), Diffuse(color=[0.8, 0.8, 0.8]))]
        if with_slab:
            objects.append(SceneObject("slab", box((2.0, 0.2, 2.0)), Glass(ior=ior), Transform(position=[0, 0.5, 0])))
        camera = Camera(position=[0.4, 3.2, 3.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=(128, 106))
        return Scene(camera=camera, objects=objects, lights=[PointLight(position=[0.3, 4.0, 0.2], intensity=[20, 20, 20])],
                     environment=procedural_environment("black"))

    with Renderer() as renderer:
        through = renderer.render(slab_scene(True), "auto")
        bare = renderer.render(slab_scene(False), "auto")
        inside = binary_erosion(renderer.exit_directions(slab_scene(True), "depth-search")[1], iterations=4)
    origins, directions = (a.reshape(-1, 3) for a in slab_scene(False).camera.primary_rays())
    floor = origins - directions * (origins[:, 1:2] / directions[:, 1:2])  # straight to y = 0
    inside &= np.all(np.abs(floor[:, [0, 2]]) < 0.7, axis=1).reshape(inside.shape)
    assert inside.sum() > 1000
    r0 = ((ior - 1.0) / (ior + 1.0)) ** 2
    assert through[inside].mean() / bare[inside].mean() == pytest.approx((1.0 - r0) ** 4, abs=0.04)


def test_a_budget_takes_the_highest_quality_that_fits(tmp_path, monkeypatch):
    monkeypatch.setenv("CAUSTICA_CACHE", str(tmp_path))
    scene = scene_of([marble(), table()], light=True, size=(40, 30))
    with Renderer() as renderer:
        renderer.render(scene, "auto", budget_ms=1e5)
        assert renderer.last_plan.quality == "high"
        measured = sorted(p.name for p in (tmp_path / "costs").iterdir())
        assert len(measured) == 1  # high fitted: the others were not measured
        with pytest.raises(TechniqueError, match=r"budget 0.001 ms is below the cheapest plan's .* ms or more"):
            renderer.render(scene, "auto", budget_ms=0.001)
        assert len(list((tmp_path / "costs").iterdir())) == 3  # high (cached), balanced and draft
        renderer.render(scene, "auto", budget_ms=1e5)  # from the cache: no frame rendered to measure
        assert renderer.last_plan.quality == "high"
    with pytest.raises(TechniqueError, match="budget_ms needs frame times"):
        from caustica.techniques import get_technique

        auto = get_technique("auto")
        auto.for_scene(scene, auto.make_params(budget_ms=10.0))


def test_a_budget_too_small_names_the_cheapest_measured_plan():
    """Frame times measured under a passing load may put draft above balanced: the smallest budget that works is
    then balanced's, and the error names it (before: draft's 38.5 ms, a budget that balanced already fits)."""
    from caustica.techniques import get_technique

    auto = get_technique("auto")
    scene = scene_of([marble(), table()], light=True, size=(40, 30))
    times = iter([50.0, 20.7, 38.5])  # high, balanced, draft, in the order they are tried

    with pytest.raises(TechniqueError, match=r"cheapest plan's 20.7 ms per frame here \(balanced\); give a budget "
                                             r"of 23 ms"):
        auto.for_scene(scene, auto.make_params(budget_ms=10.0), frame_ms=lambda technique, values: next(times))


def test_budget_options_are_checked(tmp_path, capsys):
    from caustica.cli import main

    out = str(tmp_path / "x.png")
    assert main(["render", "glass-sphere", "-o", out, "--budget", "0"]) == 2
    assert "--budget" in capsys.readouterr().err
    assert main(["render", "glass-sphere", "-o", out, "-t", "env-map", "--budget", "20"]) == 2
    assert "applies to the auto technique" in capsys.readouterr().err
    assert main(["render", "glass-sphere", "-o", out, "--size", "32x24", "--frames", "1", "-t", "env-map",
                 "--explain"]) == 0
    assert "named" in capsys.readouterr().out


def test_plan_with_a_budget_names_the_quality_that_fits_and_the_smallest_budget_that_works(tmp_path, monkeypatch,
                                                                                          capsys):
    from caustica.cli import main

    monkeypatch.setenv("CAUSTICA_CACHE", str(tmp_path))
    assert main(["plan", "glass-sphere", "--size", "32x24", "--budget", "100000", "--json"]) == 0
    planned = json.loads(capsys.readouterr().out)
    assert planned["quality"] == "high"
    assert any(note.startswith("budget 100000 ms: high, the highest quality that fits") for note in planned["notes"])
    assert main(["plan", "glass-sphere", "--size", "32x24", "--budget", "0.001"]) == 2
    err = capsys.readouterr().err
    assert "below the cheapest plan's" in err and "give a budget of" in err and "Traceback" not in err
    with Renderer((32, 24)) as renderer:  # the API: the same plan as a render with that budget takes
        chosen = renderer.plan(caustica.load_scene("glass-sphere"), budget_ms=1e5)
        renderer.render(caustica.load_scene("glass-sphere"), "auto", budget_ms=1e5)
        assert (chosen.quality, chosen.technique, chosen.params) == (
            renderer.last_plan.quality, renderer.last_plan.technique, renderer.last_plan.params)


def knot_of_glass():
    """A glass (2, 3) torus knot standing over the table under a light: half the caustic light crosses it four
    times or more (measured 0.49 of the flux beyond two interfaces)."""
    from caustica.scene.shapes import torus_knot

    knot = SceneObject("knot", torus_knot(2, 3, 0.4, 0.12, segments=96, sides=12), Glass(ior=1.5),
                       Transform(position=[0.2, 0.6, -0.2], rotation=[70.0, 0.0, 0.0]))
    return scene_of([knot, table()], light=True, size=(48, 36))


def ring_of_glass():
    """A glass torus lying on its side over the table, lit from above: not convex, but the light crosses its
    tube twice (measured 0.007 of the caustic flux beyond two interfaces)."""
    from caustica.scene.shapes import torus

    ring = SceneObject("ring", torus(0.5, 0.18, 32, 12), Glass(ior=1.5), Transform(position=[0.2, 0.4, -0.2]))
    return scene_of([ring, table()], light=True, size=(48, 36))


def test_the_traced_table_gives_the_caustics_where_light_crosses_the_glass_more_than_twice(tmp_path, monkeypatch):
    """With nothing cached, auto plans transport-table with its rays traced for the light on the knot (0.49 of the
    caustic flux beyond two interfaces), its photons by quality (draft 2^16, balanced 2^17, high 2^18; the
    technique's own default is 2^18), and the render makes no table, in memory or on disk. Glass whose light
    crosses it twice keeps caustic mapping (docs/auto.md: as accurate or more there): a ring lying flat (not
    convex, 0.007 beyond two) and a convex marble; a ring standing (0.29) takes the table."""
    from caustica.planning.probes import caustic_paths
    from caustica.transport.runtime import has_cached_table, table_mesh

    monkeypatch.setenv("CAUSTICA_CACHE", str(tmp_path / "cache"))
    scene = knot_of_glass()
    knot = scene.objects[0]
    for quality, photons in (("draft", 1 << 16), ("balanced", 1 << 17), ("high", 1 << 18)):
        planned = plan(scene, quality)
        assert planned.technique == "impostors+transport-table" and not planned.notes, quality
        assert planned.params["transport-table.exit_rays"] == "traced"
        assert planned.params["transport-table.photon_budget"] == photons
    assert "traced for the light's own directions (no table)" in planned.objects[1].reason
    with Renderer() as renderer:
        image = renderer.render(scene, quality="draft")
        assert renderer.last_plan.technique == "impostors+transport-table" and np.isfinite(image).all()
    assert not has_cached_table(table_mesh(knot.mesh), 1.5)
    assert not (tmp_path / "cache" / "transport").exists()
    for glassy in (ring_of_glass(), scene_of([marble(), table()], light=True)):
        assert plan(glassy).technique == "impostors+caustic-mapping" and not plan(glassy).notes
    # A ring standing sends 0.29 of it beyond two interfaces (under a third: caustic mapping until TABLE_SHARE
    # fell to 0.05; docs/auto.md, "Which glass takes the traced table").
    from caustica.scene.shapes import torus

    ring = SceneObject("ring", torus(0.4, 0.14, 32, 12), Glass(ior=1.5),
                       Transform(position=[0.2, 0.6, -0.2], rotation=[90.0, 0.0, 0.0]))
    standing = scene_of([ring, table()], light=True, size=(48, 36))
    share = caustic_paths(standing, standing.lights).beyond_two
    assert 0.05 < share < 1.0 / 3.0, share
    assert plan(standing).technique == "impostors+transport-table"


def test_convex_glass_keeps_caustic_mapping_where_its_light_reflects_inside():
    """A glass cylinder standing under a light sends most of its caustic through three interfaces or more (in
    at the top, totally reflected off the side wall, out at the bottom): caustic mapping follows those paths
    (exit_reflections), so a transport table would not pay there, while the same share through a knot does."""
    from caustica.planning.probes import caustic_paths
    from caustica.planning.rules import _traced_table_pays
    from caustica.scene.shapes import cylinder

    glass = SceneObject("cylinder", cylinder(0.25, 0.8, 32), Glass(ior=1.5), Transform(position=[0.0, 0.45, 0.0]))
    scene = scene_of([glass, table()], light=True, size=(48, 36))
    share = caustic_paths(scene, scene.lights).beyond_two
    assert share > 1.0 / 3.0, share
    assert not _traced_table_pays([glass], share)
    knot = knot_of_glass().objects[0]
    assert _traced_table_pays([knot], share)


# ---- what the plan leaves out where it buys nothing (issue 19: auto's cost) ---------------------------------


def lens_before_a_chart(size=(64, 48)) -> Scene:
    """A thin lens before a flat chart of tiles under the sky-checker sky, no lights: the sun (travelling
    towards +z) lights the chart's back, and the lens sends its light towards the camera; the tiles lie in one
    plane, so no opaque object hides any of the sky from a diffuse surface."""
    from caustica.scene.presets_per_vertex import test_chart
    from caustica.scene.shapes import biconvex_lens

    lens = SceneObject("lens", biconvex_lens(0.3, 0.08, 0.01, 48, 12), Glass(ior=1.5))
    camera = Camera(position=[0.05, -0.03, 0.8], look_at=[0.0, 0.0, -0.3], fov_y=36.0, size=size)
    return Scene(camera=camera, objects=[lens, *test_chart(center=(0.0, 0.0, -0.6), size=0.9, cells=6)],
                 environment=procedural_environment("sky-checker"))


def test_lobes_and_caustics_that_change_no_pixel_are_left_out():
    """A caustic map changes no pixel of the lens before the chart, and the lobes next to none (the lens dims a
    sliver of the chart's sky by its 8 % Fresnel loss: 0.3 % of the sky's light, under LOBE_SHARE): the plan has
    neither, says why, and its image is the one rendered with the caustic map, and within 0.1 % on average of
    the one with the lobes."""
    from caustica.lighting.environment import lobe_occlusion
    from caustica.planning.probes import LOBE_SHARE

    scene = lens_before_a_chart()
    assert 0.0 < lobe_occlusion(scene) < LOBE_SHARE
    chosen = plan(scene)
    assert chosen.technique == "impostors"
    assert "no caustics" in chosen.describe()
    with Renderer() as renderer:
        image = renderer.render(scene, "auto")
        assert renderer.last_plan.technique == "impostors"
        lobes = renderer.render(scene, "auto", environment_lobes=16)  # given by name: honoured
        caustics = renderer.render(scene, "impostors+caustic-mapping", **chosen.params)
    assert np.abs(image - lobes).mean() < 1e-3 * image.mean() and not np.array_equal(image, lobes)
    assert np.array_equal(image, caustics)


def test_lobes_are_kept_where_an_opaque_object_hides_sky():
    """A box on the table hides part of the sky from it: the share (8 %) is well above LOBE_SHARE and the plan keeps
    the lobes (the environment is the only light); the glass ball alone dims the table's sky by 0.7 %."""
    from caustica.lighting.environment import lobe_occlusion
    from caustica.planning.probes import LOBE_SHARE, occluded_ambient

    block = SceneObject("block", box((0.5, 0.5, 0.5)), Diffuse(color=[0.5, 0.5, 0.5]),
                        Transform(position=[-0.4, 0.25, 0]))
    scene = scene_of([marble(), table(), block])
    assert lobe_occlusion(scene) > 5 * LOBE_SHARE and occluded_ambient(scene)
    alone = scene_of([marble(), table()])
    assert 0.0 < lobe_occlusion(alone) < LOBE_SHARE and not occluded_ambient(alone)


def test_exit_shares_of_a_ball_have_the_closed_form():
    """In a ball every internal angle is the refraction angle, so the light that entered leaves at exit k with
    share (1 - F) F^k, F the Fresnel reflectance at that angle (equal to the entry's): per pixel from the
    analytic hit, averaged over the ball's pixels."""
    from caustica.raytrace.optics import fresnel_dielectric
    from caustica.raytrace.paths import exit_shares

    ior, radius = 1.5, 0.6
    ball = SceneObject("ball", sphere(radius, 4), Glass(ior=ior))
    camera = Camera(position=[0.0, 0.0, 3.0], look_at=[0.0, 0.0, 0.0], fov_y=30.0, size=(64, 64))
    scene = Scene(camera=camera, objects=[ball], environment=procedural_environment("sky-checker"))
    origin, direction = (a[:, :, 0].reshape(-1, 3) for a in camera.primary_rays())
    b = np.einsum("ij,ij->i", origin, direction)
    disc = b * b - (np.einsum("ij,ij->i", origin, origin) - radius**2)
    hit = disc > 0
    t = -b[hit] - np.sqrt(disc[hit])
    normal = (origin[hit] + t[:, None] * direction[hit]) / radius
    cos_i = -np.einsum("ij,ij->i", direction[hit], normal)
    f = fresnel_dielectric(cos_i, 1.0, ior)
    expected = [float(((1 - f) * f**k).mean()) for k in range(3)]
    assert exit_shares(scene, camera, 3) == pytest.approx(expected, rel=0.02, abs=2e-4)


def test_glass_exits_are_exact_for_spheres_convex_polyhedra_and_lenses():
    """auto sets depth-search's convex_exits (passes/shading/convex_exits.py) wherever it plans glass: alone or with
    impostors; a ball, a block and a lens (two spherical faces and a round rim) get exact shapes, a torus keeps
    the search."""
    from caustica.passes.shading.convex_exits import convex_shape
    from caustica.scene.shapes import box, torus

    assert plan(scene_of([marble()])).params["convex_exits"] is True
    assert plan(lens_before_a_chart()).params["convex_exits"] is True
    block = SceneObject("block", box((1.6, 0.5, 1.0)), Glass(ior=1.5), Transform(position=[0.6, 0.85, 0.4]))
    planes = convex_shape(block).planes
    assert planes.shape == (6, 4) and np.allclose(planes[np.argmax(planes[:, 1]), 3], 1.1)  # the top at y = 1.1
    ball = convex_shape(marble()).quadrics
    assert ball.shape == (1, 8) and ball[0, 3] > 0 and not ball[0, 7]
    lens = convex_shape(lens_before_a_chart().objects[0]).quadrics
    assert sorted(lens[:, 7]) == [0.0, 0.0, 1.0]
    assert convex_shape(SceneObject("ring", torus(1.0, 0.3), Glass(ior=1.5))) is None


def test_internal_bounces_are_followed_where_they_carry_light():
    """balanced follows the second internal bounce in a ball (1.2 percent of its glass pixels' light) and not
    in a thin lens (0.05 percent), and says so; high follows every bounce of its quality."""
    ball = plan(scene_of([marble()]))
    assert ball.params["internal_bounces"] == 2 and not ball.notes
    lens = plan(lens_before_a_chart())
    assert lens.params["internal_bounces"] == 1
    assert any("internal bounce" in note for note in lens.notes)
    assert plan(lens_before_a_chart(), "high").params["internal_bounces"] == 4


def test_a_water_sheet_takes_no_internal_bounce():
    """caustics-pool's water is an open sheet: the light refracted into it lands on the floor, leaving by no glass
    exit (exit_shares all zero; NaN with no glass in view), so no bounce is followed, and the two the quality
    allows change no pixel of the image (they cost 0.4x plain's CPU time each)."""
    from caustica.raytrace.paths import exit_shares

    pool = caustica.load_scene("caustics-pool")
    assert np.array_equal(exit_shares(pool, pool.camera.with_size(64, 48), 3), np.zeros(3))
    away = Camera(position=[0.0, 3.6, 3.6], look_at=[0.0, 5.0, 5.0], fov_y=40.0, size=(64, 48))  # at the sky
    assert np.isnan(exit_shares(pool, away, 3)).all()
    chosen = plan(pool)
    assert chosen.params["internal_bounces"] == 0 and any("2 internal bounce(s)" in note for note in chosen.notes)
    with Renderer((64, 48)) as renderer:
        image = renderer.render(pool, "auto")
        bounced = renderer.render(pool, "auto", internal_bounces=2)
    np.testing.assert_allclose(image, bounced, atol=1e-6)


def test_glass_takes_its_fresnel_loss_and_absorption_from_a_lobe():
    """A ray through a glass slab 0.2 thick at normal incidence keeps (1 - F0)^2 exp(-sigma 0.2), F0 = ((n - 1) /
    (n + 1))^2 at each interface and sigma the absorption coefficient's mean; a ray beside it loses nothing."""
    from caustica.lighting.environment import _glass_loss

    glass = Glass(ior=1.5, absorption_color=[0.5, 0.6, 0.7], absorption_distance=1.0)
    slab = SceneObject("slab", box((2.0, 0.2, 2.0)), glass, Transform(position=[0.0, 1.0, 0.0]))
    loss = _glass_loss([slab], np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]] * 2), 1e-6)
    sigma = float(np.mean(-np.log([0.5, 0.6, 0.7])))
    assert loss == pytest.approx([1.0 - (1.0 - 0.04) ** 2 * np.exp(-sigma * 0.2), 0.0], abs=1e-6)


def test_the_caustic_map_follows_the_frame_size():
    from caustica.planning.rules import caustic_map_size

    # Twice the longer side as a power of two, at least 256, at most the quality's.
    assert [caustic_map_size(512, s) for s in ((64, 48), (128, 128), (129, 90), (256, 256), (1920, 1080))] == \
        [256, 256, 512, 512, 512]
    assert caustic_map_size(1024, (400, 300)) == 1024 and caustic_map_size(256, (1920, 1080)) == 256
    lit = scene_of([marble(), table()], light=True, size=(96, 72))
    assert plan(lit).params["caustic-mapping.map_size"] == 256  # the camera's size by default
    assert plan(lit, frame_size=(300, 200)).params["caustic-mapping.map_size"] == 512
    with Renderer() as renderer:  # a frame's supersampled size is what the renderer plans for
        renderer.render(lit, "auto", 4)
        assert renderer.last_plan.params["caustic-mapping.map_size"] == 512
        renderer.render(lit, "auto", 1)
        assert renderer.last_plan.params["caustic-mapping.map_size"] == 256


def test_a_small_frame_s_smaller_caustic_map_is_as_close_to_exact():
    """At 96x96 the planned 256 map's caustic is as close to exact's photon-mapped caustic as the 512 map's
    (docs/auto.md measured 0.0039 against 0.0054 at 128x128 on this ball), for a quarter of the photons."""
    from caustica.metrics.images import relmse
    from caustica.metrics.regions import region_masks

    ball = sphere(0.5, 5)
    ball.analytic_sphere = (np.zeros(3), 0.5)
    scene = Scene(camera=Camera(position=[1.3, 1.8, 2.4], look_at=[0.0, 0.2, 0.0], fov_y=40.0, size=(96, 96)),
                  objects=[SceneObject("floor", plane((6.0, 6.0)), Diffuse(color=[0.75, 0.75, 0.75])),
                           SceneObject("ball", ball, Glass(ior=1.5), Transform(position=[0.0, 0.8, 0.0]))],
                  lights=[PointLight(position=[0.4, 3.0, -0.3], intensity=[8.0] * 3)],
                  environment=procedural_environment("black"))
    caustic = region_masks(scene)["caustic"]
    assert caustic.sum() > 100
    with Renderer() as renderer:
        reference = renderer.render(scene, "exact", 1)
        planned = renderer.render(scene, "auto", 1)
        assert renderer.last_plan.params["caustic-mapping.map_size"] == 256
        larger = renderer.render(scene, "auto", 1, **{"caustic-mapping.map_size": 512})
    assert relmse(planned, reference, caustic) <= 1.25 * relmse(larger, reference, caustic)
    assert relmse(planned, reference, caustic) < 0.03


def clear_ball(name="clear"):
    """Glass that no light sees: IOR 1, no absorption (Glass.invisible)."""
    return SceneObject(name, sphere(0.45, 3), Glass(ior=1.0), Transform(position=[0.3, 0.55, -0.2]))


def checker_wall():
    """A wall of 8 x 8 checks behind the ball, as the camera sees it (the texture is what glass would bend)."""
    checks = (np.indices((64, 64)).sum(axis=0) // 8 % 2).astype(np.float32)
    texture = np.repeat((0.15 + 0.8 * checks)[..., None], 3, axis=-1)
    return SceneObject("wall", plane((3.0, 2.0)), Diffuse(color=[0.9, 0.8, 0.7], texture=texture),
                       Transform(position=[0.0, 1.0, -1.2], rotation=[90, 0, 0]))


def test_invisible_glass_is_left_out_and_auto_renders_the_scene_without_it():
    """A ball of IOR 1 that absorbs nothing, before a checkered wall over a table under a light: auto leaves it
    out (its plan entry says why), so the image is the one of the scene without it, which a path tracer also
    gives. Before, auto planned impostors for it: its impostor lookups and caustic map changed the pixels."""
    scene = scene_of([clear_ball(), checker_wall(), table()], light=True, size=(64, 48))
    without = scene_of([checker_wall(), table()], light=True, size=(64, 48))
    chosen = plan(scene)
    entry = chosen.objects[0]
    assert (entry.object, entry.handled_by) == ("clear", "left out") and "IOR 1 and no absorption" in entry.reason
    assert [e.object for e in chosen.objects] == ["clear", "wall", "table"]
    assert chosen.params.pop("drop_invisible_glass") is True
    assert (chosen.technique, chosen.params) == (plan(without).technique, plan(without).params)
    with Renderer() as renderer:
        image = renderer.render(scene, "auto", spp=4)
        chosen = renderer.last_plan
        assert chosen.objects[0].handled_by == "left out"
        expected = renderer.render(without, "auto", spp=4)
        assert np.abs(image - expected).max() <= 1e-5
        # The plan's technique and parameters give auto's image; the labels still see the ball.
        named = renderer.render(scene, chosen.technique, spp=4, **chosen.params)
        assert np.array_equal(named, image)
        _, layers = renderer.render(scene, "auto", labels=["id", "glass"])
        assert layers["glass"].sum() > 100 and (layers["id"][layers["glass"] > 0] == 0).all()


def test_glass_that_tints_or_bends_is_not_left_out():
    """Only air-like glass is left out: IOR 1.001, or IOR 1 with absorption, stays in the glass passes."""
    for material in (Glass(ior=1.001), Glass(ior=1.0, absorption_color=[0.9, 0.9, 1.0])):
        ball = SceneObject("ball", sphere(0.45, 3), material, Transform(position=[0.3, 0.55, -0.2]))
        chosen = plan(scene_of([ball, table()], light=True))
        assert "drop_invisible_glass" not in chosen.params and chosen.objects[0].handled_by != "left out"
    assert Glass(ior=1.0, abbe=40.0).invisible and not Glass(ior=1.5).invisible


@pytest.mark.parametrize("preset, view", [("cylinder-mirror", "impostors"), ("saddle-mirror", "impostors"),
                                          ("mirror-patches", "impostors"), ("mirror-convex", "impostors"),
                                          ("mirror-flat", "per-vertex"), ("mirror-in-mirror", "per-vertex"),
                                          ("door-mirror", "per-vertex")])
def test_mirrors_far_from_one_viewpoint_take_impostors(preset, view):
    """Per-vertex's least-squares viewpoint serves mirrors whose rays nearly meet in one point (flat, the door
    mirror's 0.04 degrees on average) and a mirror in a mirror (Kakimoto et al. 4.4); the rays of the cylinder,
    the saddle, the two patches and mirror-convex pass it at 3.3, 10, 0.77 / 0.92 and 0.47 degrees (PARALLAX
    0.3), where impostors renders them 0.6 to 5.0 dB closer to the completed reference (docs/auto.md). Before,
    all four planned per-vertex."""
    chosen = plan(caustica.load_scene(preset))
    assert chosen.technique.split("+")[0] == view
    if view == "impostors":
        assert "pass far from one viewpoint" in chosen.objects[0].reason
