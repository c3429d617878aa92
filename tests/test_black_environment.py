"""`--environment black` (issue 43): plan plans for the scene the render will have, and no work is spent on
an environment's light where it brings nothing (the bake, exact's environment rays)."""
from __future__ import annotations

import numpy as np

import caustica
import caustica.lighting.bake as light_bake
from caustica.cli import main
from caustica.scene.environment import environment_option
from caustica.scene.materials import Diffuse
from caustica.techniques import get_technique
from caustica.techniques.exact import environment_sampling


def test_plan_takes_the_environment_option(capsys):
    assert main(["plan", "caustic-sphere"]) == 0
    sky = capsys.readouterr().out
    assert "the environment's sun among them" in sky and "the environment's light on it" in sky
    assert main(["plan", "caustic-sphere", "--environment", "black"]) == 0
    black = capsys.readouterr().out
    assert "caustics from 1 light(s)" in black
    assert "sun" not in black and "the environment's light" not in black, black
    assert "the environment is black and adds nothing" in black


def diffuse_ball(environment: str):
    """caustic-sphere with a diffuse ball: no glass, so a black environment leaves the light maps nothing."""
    scene = caustica.load_scene("caustic-sphere")
    scene.objects[0].material = Diffuse(color=[0.6, 0.3, 0.2])
    scene.environment = environment_option(environment)
    return scene


def test_a_black_environment_runs_no_bake_and_the_image_is_unchanged(monkeypatch):
    bakes = []
    real = light_bake._scene_bake
    monkeypatch.setattr(light_bake, "_scene_bake", lambda *a, **k: bakes.append(a) or real(*a, **k))
    with caustica.Renderer((32, 24)) as renderer:
        renderer.render(diffuse_ball("sky-checker"))
        assert len(bakes) == 1  # the counter counts: under a sky the floor and the ball are baked
        bakes.clear()
        black = renderer.render(diffuse_ball("black"))
        assert bakes == [] and "environment_bake" not in renderer.last_plan.params
        unbaked = renderer.render(diffuse_ball("black"), environment_bake=0)
    assert np.array_equal(black, unbaked)


def test_exact_traces_no_environment_rays_where_they_bring_nothing():
    """A black environment with no light for the rays' bounce: no environment rays, the same image. With a
    light the rays stay (they carry its light one bounce on; 0.2 % of caustic-sphere's mean)."""
    exact = get_technique("exact")
    scene = caustica.load_scene("caustic-sphere")
    scene.environment = environment_option("black")
    assert environment_sampling(scene, exact.make_params()) is not None  # the lights' bounce
    params = {"caustic_photons": 0, "environment_bounce": False}
    assert environment_sampling(scene, exact.make_params(**params)) is None
    with caustica.Renderer((24, 16)) as renderer:
        skipped = renderer.render(scene, "exact", **params)
        unoccluded = renderer.render(scene, "exact", caustic_photons=0, environment_samples=0)
    assert np.array_equal(skipped, unoccluded) and skipped.max() > 0
    scene.lights = []
    assert environment_sampling(scene, exact.make_params()) is None
    scene.environment = environment_option("sky-checker")
    assert environment_sampling(scene, exact.make_params()) is not None
