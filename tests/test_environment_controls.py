"""Environment controls: ``[environment] rotation`` and ``strength``, ``Environment.rotated`` / ``scaled``,
and ``--environment`` on the command line."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from caustica.cli import main
from caustica.errors import EnvironmentImageError, SceneError
from caustica.images import read_image, write_image
from caustica.scene import Camera, Scene, procedural_environment
from caustica.scene.environment import Environment, environment_option, uv_to_direction
from caustica.scene.io import parse_scene


def rotation_y(degrees: float) -> np.ndarray:
    """The right-handed rotation about +Y (counter-clockwise seen from above)."""
    a = np.radians(degrees)
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def random_environment(width=16, height=8, seed=1) -> Environment:
    return Environment(np.random.default_rng(seed).random((height, width, 3), dtype=np.float32), source="test")


def random_directions(n=500, seed=2) -> np.ndarray:
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


# -- rotation ------------------------------------------------------------------------------------


def test_rotation_by_90_degrees_turns_north_east_to_north_west():
    """Seen from above (+Y), -Z is north and +X east; column 0 of a 4-wide image is centred at azimuth 45
    degrees, the north-east. Turned counter-clockwise by 90 degrees it lies north-west: column 3."""
    image = np.zeros((3, 4, 3), np.float32)
    image[1, 0] = [5.0, 4.0, 3.0]
    env = Environment(image, source="test")
    north_east = np.array([np.sqrt(0.5), 0.0, -np.sqrt(0.5)])
    north_west = np.array([-np.sqrt(0.5), 0.0, -np.sqrt(0.5)])
    assert np.allclose(env.lookup(north_east), [5, 4, 3])
    turned = env.rotated(90.0)
    assert np.array_equal(turned.image[:, 3], image[:, 0])
    assert np.allclose(turned.lookup(north_west), [5, 4, 3], atol=1e-5)
    assert np.allclose(turned.lookup(north_east), 0.0, atol=1e-5)
    assert (turned.rotation, turned.strength, turned.source) == (90.0, 1.0, "test")
    assert np.array_equal(env.image, image)  # the original is untouched


@pytest.mark.parametrize("columns", [1, 3, -5, 16, 21])
def test_rotated_lookup_is_the_original_seen_through_the_rotation(columns):
    """For a whole number of columns (360 / W degrees each) rotated(a).lookup(R_y(a) d) == lookup(d)."""
    env = random_environment()
    degrees = 360.0 / env.image.shape[1] * columns
    d = random_directions()
    turned = env.rotated(degrees)
    assert np.allclose(turned.lookup(d @ rotation_y(degrees).T), env.lookup(d), atol=2e-5)


def test_fractional_rotation_interpolates_along_each_row():
    env = random_environment(width=8)
    half = env.rotated(360.0 / 8 * 2.5)  # two and a half columns
    expected = 0.5 * (np.roll(env.image, -2, axis=1) + np.roll(env.image, -3, axis=1))
    assert np.allclose(half.image, expected, atol=1e-6)
    # The rotation of a smooth image is close to exact: the seam and every row wrap around.
    assert np.allclose(half.image.mean(axis=1), env.image.mean(axis=1), atol=1e-6)


def test_rotations_add_and_a_full_turn_is_the_identity():
    env = random_environment()
    step = 360.0 / 16
    assert np.array_equal(env.rotated(3 * step).rotated(2 * step).image, env.rotated(5 * step).image)
    assert np.array_equal(env.rotated(360.0).image, env.image)
    assert np.array_equal(env.rotated(-step).image, env.rotated(15 * step).image)
    assert env.rotated(3 * step).rotated(2 * step).rotation == pytest.approx(5 * step)


# -- strength ------------------------------------------------------------------------------------


def test_strength_scales_radiance_and_irradiance_linearly():
    env = procedural_environment("sky-checker")
    bright = env.scaled(2.5)
    assert np.allclose(bright.image, 2.5 * env.image, rtol=1e-6)
    assert np.allclose(bright.irradiance_sh(), 2.5 * env.irradiance_sh(), rtol=1e-4, atol=1e-5)
    assert bright.strength == 2.5 and bright.scaled(2.0).strength == 5.0
    assert np.array_equal(env.scaled(0.0).image, np.zeros_like(env.image))
    assert bright.rotated(30).describe() == "procedural:sky-checker, rotated 30 degrees about +Y, strength 2.5"


@pytest.mark.parametrize("bad, fragment", [(-1.0, "environment.strength"), (float("nan"), "environment.strength"),
                                           (1e13, "environment.strength")])
def test_bad_strength_is_refused(bad, fragment):
    with pytest.raises(EnvironmentImageError, match=fragment):
        procedural_environment("white").scaled(bad)


def test_bad_rotation_is_refused():
    for bad in (float("inf"), "90", 1e7):
        with pytest.raises(EnvironmentImageError, match="environment.rotation"):
            procedural_environment("white").rotated(bad)


# -- scene files ---------------------------------------------------------------------------------


def scene_with(environment: dict) -> Scene:
    return parse_scene({"environment": environment}, base_dir=Path("."), default_name="test")


def test_toml_rotation_and_strength_bake_the_same_image_as_the_api():
    env = scene_with({"procedural": "sky-checker", "rotation": 45.0, "strength": 3}).environment
    expected = procedural_environment("sky-checker").rotated(45.0).scaled(3.0)
    assert np.array_equal(env.image, expected.image)
    assert (env.rotation, env.strength) == (45.0, 3.0)


def test_toml_without_the_keys_keeps_the_image_bit_identical():
    env = scene_with({}).environment
    assert np.array_equal(env.image, procedural_environment("sky-checker").image)
    assert (env.rotation, env.strength) == (0.0, 1.0)


def test_toml_environment_file_with_rotation(tmp_path):
    image = np.random.default_rng(3).random((4, 8, 3), dtype=np.float32)
    write_image(tmp_path / "sky.exr", image)
    scene = parse_scene({"environment": {"file": "sky.exr", "rotation": 90}}, base_dir=tmp_path, default_name="t")
    assert np.array_equal(scene.environment.image, np.roll(image, -2, axis=1))


@pytest.mark.parametrize("table, fragment", [
    ({"strength": -2}, "environment.strength -2.0 must be a number in [0,"),
    ({"rotation": "north"}, "environment.rotation must be a finite number"),
    ({"rotaton": 10}, "did you mean 'rotation'"),
])
def test_toml_bad_values_name_the_key(table, fragment):
    with pytest.raises(SceneError) as info:
        scene_with(table)
    assert fragment in str(info.value)


# -- rendered background -------------------------------------------------------------------------


def band_environment() -> Environment:
    """Black but for one bright column centred at azimuth 10.5 degrees (1 degree a column)."""
    image = np.zeros((90, 360, 3), np.float32)
    image[:, 10] = [0.5, 0.25, 0.125]
    return Environment(image, source="band")


def brightest_azimuth(renderer, environment: Environment) -> tuple[float, np.ndarray]:
    """Azimuth (degrees, atan2(x, -z)) of the brightest pixel on the horizon row of a ``plain`` render looking
    at -Z, and that pixel's colour."""
    camera = Camera(position=[0, 0, 0], look_at=[0, 0, -1], fov_y=40.0, size=(96, 33))
    image = renderer.render(Scene(camera=camera, environment=environment), "plain")
    row = image.shape[0] // 2
    column = int(np.argmax(image[row, :, 0]))
    _, dirs = camera.primary_rays()
    d = dirs[row, column, 0]
    return float(np.degrees(np.arctan2(d[0], -d[2]))), image[row, column]


def test_plain_background_moves_by_the_rotation_and_scales_by_the_strength(renderer):
    """The band at azimuth 10.5 (right of the view centre) turned counter-clockwise by 20 degrees lies at
    -9.5 (left of it); one pixel spans about 0.56 degrees."""
    before, colour = brightest_azimuth(renderer, band_environment())
    assert before == pytest.approx(10.5, abs=0.6)
    after, _ = brightest_azimuth(renderer, band_environment().rotated(20.0))
    assert after == pytest.approx(-9.5, abs=0.6)
    _, tripled = brightest_azimuth(renderer, band_environment().scaled(3.0))
    assert colour[0] > 0.1
    assert np.allclose(tripled, 3.0 * colour, rtol=1e-3)


# -- command line --------------------------------------------------------------------------------


def run_cli(args, capsys):
    code = main([str(a) for a in args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_environment_option_resolves_names_and_files(tmp_path):
    assert environment_option("white").source == "procedural:white"
    write_image(tmp_path / "sky.exr", np.full((4, 8, 3), 0.25, np.float32))
    assert np.allclose(environment_option(str(tmp_path / "sky.exr")).image, 0.25)


@pytest.mark.parametrize("option, background", [("black", 0), ("white", 255)])
def test_cli_environment_sets_the_background(tmp_path, capsys, option, background):
    out = tmp_path / "bg.png"
    code, stdout, _ = run_cli(["render", "glass-sphere", "-t", "plain", "--size", "32x24", "--frames", "1",
                               "--environment", option, "-o", out], capsys)
    assert code == 0 and "wrote" in stdout
    image = np.round(read_image(out) * 255)  # decoded from sRGB: 0 and 255 are exact
    corners = image[[0, 0, -1, -1], [0, -1, 0, -1]]
    assert np.all(corners == background)
    default = tmp_path / "default.png"
    assert run_cli(["render", "glass-sphere", "-t", "plain", "--size", "32x24", "--frames", "1", "-o", default],
                   capsys)[0] == 0
    assert not np.all(np.round(read_image(default) * 255)[[0, 0, -1, -1], [0, -1, 0, -1]] == background)


@pytest.mark.parametrize("command", [["render", "glass-sphere", "-o", "{out}"], ["compare", "glass-sphere"],
                                     ["bench", "--scenes", "glass-sphere", "--no-mitsuba"], ["view", "glass-sphere"]])
@pytest.mark.parametrize("option, fragment", [
    ("blak", "did you mean 'black'"),
    ("missing.exr", "environment file not found"),
    ("{bad}", "cannot read image"),
])
def test_cli_bad_environment_is_one_line_exit_2(tmp_path, capsys, command, option, fragment):
    if command[0] == "view":
        pytest.importorskip("glfw", reason="the viewer needs the 'viewer' extra")
        import os

        if not os.environ.get("DISPLAY"):
            pytest.skip("the viewer checks the display before the scene; no DISPLAY here")
    bad = tmp_path / "broken.exr"
    bad.write_bytes(b"not an exr")
    args = [a.format(out=tmp_path / "x.png") for a in command]
    code, _, err = run_cli(args + ["--environment", option.format(bad=bad)], capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("caustica: "), err
    assert fragment in lines[0] and "Traceback" not in err
    assert not (tmp_path / "x.png").exists()
