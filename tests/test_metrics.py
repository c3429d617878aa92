"""caustica.metrics: image errors, angular errors, scene regions."""
from __future__ import annotations

import math

import numpy as np
import pytest

import caustica
from caustica.scene import Camera
from caustica.metrics import (
    caustic_region,
    REGIONS,
    angular_error,
    compare_images,
    exact_exit_directions,
    flip,
    flip_error_map,
    flip_map,
    psnr_linear,
    psnr_srgb,
    region_masks,
    relmse,
    ssim,
)

SIZE = 64


def _smooth_image(height=SIZE, width=SIZE, seed=0) -> np.ndarray:
    """A smooth colourful image inside [0.1, 0.8]."""
    y, x = np.mgrid[0:height, 0:width] / max(height, width)
    rng = np.random.default_rng(seed)
    phase = rng.uniform(0, 2 * np.pi, 3)
    channels = [0.45 + 0.35 * np.sin(5 * x + 3 * y + p) * np.cos(2 * y - p) for p in phase]
    return np.stack(channels, axis=-1)


def _srgb(v: float) -> float:
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055


# -- image metrics --------------------------------------------------------------


def test_identical_images_are_perfect():
    ref = _smooth_image()
    assert psnr_linear(ref, ref) == math.inf
    assert psnr_srgb(ref, ref) == math.inf
    assert relmse(ref, ref) == 0.0
    assert ssim(ref, ref) == pytest.approx(1.0, abs=1e-12)
    assert flip(ref, ref) == 0.0


@pytest.mark.parametrize("c", [0.01, 0.05, 0.2])
def test_psnr_of_constant_offset(c):
    ref = _smooth_image() * (1 - c) / 0.8  # inside [0, 1 - c]
    assert ref.max() <= 1 - c
    assert psnr_linear(ref + c, ref) == pytest.approx(-20 * math.log10(c), rel=1e-9)


def test_psnr_clips_to_unit_range():
    ref = np.full((8, 8, 3), 0.5)
    assert psnr_linear(np.full_like(ref, 1.0), ref) == psnr_linear(np.full_like(ref, 7.0), ref)
    assert psnr_linear(np.full_like(ref, -3.0), np.zeros_like(ref)) == math.inf


def test_psnr_srgb_of_known_pair():
    ref = np.zeros((4, 6, 3))
    x = np.zeros((4, 6, 3))
    ref[:2], x[:2] = 0.2, 0.3  # gamma segment
    ref[2:], x[2:] = 0.001, 0.002  # linear segment
    x[0, 0, 0] = 1.7  # clipped to 1
    diffs = np.where(ref == 0.2, _srgb(0.3) - _srgb(0.2), _srgb(0.002) - _srgb(0.001))
    diffs[0, 0, 0] = 1.0 - _srgb(0.2)
    expected = 10 * math.log10(1.0 / np.mean(diffs**2))
    assert psnr_srgb(x, ref) == pytest.approx(expected, rel=1e-12)


def test_relmse_closed_form():
    ref = np.full((5, 7, 3), 0.5)
    assert relmse(np.full_like(ref, 0.6), ref) == pytest.approx(0.01 / (0.25 + 0.01), rel=1e-12)
    # unclipped values
    assert relmse(np.full_like(ref, 3.0), np.full_like(ref, 2.0)) == pytest.approx(1.0 / 4.01, rel=1e-12)


def test_masked_metrics():
    ref = np.full((8, 8, 3), 0.5)
    x = ref.copy()
    x[:, 4:] += 0.1
    left = np.zeros((8, 8), bool)
    left[:, :4] = True
    assert psnr_linear(x, ref, left) == math.inf
    assert psnr_linear(x, ref, ~left) == pytest.approx(20.0, rel=1e-9)
    assert relmse(x, ref, ~left) == pytest.approx(0.01 / 0.26, rel=1e-9)
    empty = np.zeros((8, 8), bool)
    for metric in (psnr_linear, psnr_srgb, relmse, ssim, flip):
        assert math.isnan(metric(x, ref, empty))


def test_full_mask_equals_unmasked():
    ref = _smooth_image()
    x = np.clip(ref + np.random.default_rng(1).normal(0, 0.05, ref.shape), 0, 1)
    full = np.ones(ref.shape[:2], bool)
    for metric in (psnr_linear, psnr_srgb, relmse, ssim, flip):
        assert metric(x, ref, full) == pytest.approx(metric(x, ref), rel=1e-6)


def test_flip_increases_with_error():
    ref = _smooth_image()
    noise = np.random.default_rng(2).normal(0, 1, ref.shape)
    errors = [flip(np.clip(ref + s * noise, 0, 1), ref) for s in (0.01, 0.05, 0.15)]
    assert 0 < errors[0] < errors[1] < errors[2] <= 1
    ssims = [ssim(np.clip(ref + s * noise, 0, 1), ref) for s in (0.01, 0.05, 0.15)]
    assert 1 > ssims[0] > ssims[1] > ssims[2]


def test_flip_maps_keep_row_zero_at_top():
    ref = np.full((32, 40, 3), 0.5)
    x = ref.copy()
    x[:4, :6] = 1.0
    errors = flip_error_map(x, ref)
    assert errors.shape == (32, 40) and errors.dtype == np.float32
    assert errors[:4, :6].mean() > 0.3 and errors[20:, 20:].max() == 0.0
    colours = flip_map(x, ref)
    assert colours.shape == (32, 40, 3) and colours.dtype == np.float32
    assert np.all((colours >= 0) & (colours <= 1))
    assert colours[1, 1].sum() > colours[25, 30].sum()  # magma: bright for large errors, dark for none
    assert np.allclose(colours[25, 30], flip_map(ref, ref)[0, 0])
    linear = flip_map(x, ref, linear=True)
    assert np.allclose(caustica.images.linear_to_srgb(linear), colours, atol=1e-5)


@pytest.mark.parametrize(
    "x, ref, mask",
    [
        (np.zeros((8, 8, 3)), np.zeros((8, 9, 3)), None),
        (np.zeros((8, 8)), np.zeros((8, 8)), None),
        (np.zeros((8, 8, 4)), np.zeros((8, 8, 4)), None),
        (np.full((8, 8, 3), np.nan), np.zeros((8, 8, 3)), None),
        (np.zeros((8, 8, 3)), np.full((8, 8, 3), np.inf), None),
        (np.zeros((8, 8, 3)), np.zeros((8, 8, 3)), np.ones((8, 7), bool)),
    ],
)
def test_metrics_reject_bad_input(x, ref, mask):
    for metric in (psnr_linear, psnr_srgb, relmse, ssim, flip):
        with pytest.raises(ValueError) as info:
            metric(x, ref, mask)
        assert "\n" not in str(info.value)


# -- directions -----------------------------------------------------------------


def _rotated(n: int, angle: float, seed=3) -> tuple[np.ndarray, np.ndarray]:
    """Random unit vectors and the same vectors rotated by ``angle`` radians about axes perpendicular to them."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    axis = np.cross(v, rng.normal(size=(n, 3)))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    w = v * math.cos(angle) + np.cross(axis, v) * math.sin(angle)  # Rodrigues, axis . v = 0
    return w, v


def test_angular_error_of_known_rotations():
    dirs, ref = _rotated(1000, math.radians(1.0))
    result = angular_error(dirs, ref)
    assert result["count"] == 1000
    assert result["mean_deg"] == pytest.approx(1.0, rel=1e-9)
    assert result["p95_deg"] == pytest.approx(1.0, rel=1e-9)


@pytest.mark.parametrize("angle", [1e-4, 1e-8])
def test_angular_error_of_tiny_rotations(angle):
    dirs, ref = _rotated(500, angle)
    assert angular_error(dirs, ref)["mean_deg"] == pytest.approx(math.degrees(angle), rel=1e-6)


def test_angular_error_images_and_validity():
    dirs, ref = _rotated(12, math.radians(2.0))
    dirs, ref = dirs.reshape(3, 4, 3), ref.reshape(3, 4, 3)
    dirs[0, 0] = -ref[0, 0]  # 180 degrees, excluded below
    mine = np.ones((3, 4), bool)
    theirs = np.ones((3, 4), bool)
    mine[0, 0] = False
    theirs[2, 3] = False
    dirs[2, 3] = np.nan
    result = angular_error(dirs, ref, (mine, theirs))
    assert result["count"] == 10
    assert result["mean_deg"] == pytest.approx(2.0, rel=1e-9)
    assert angular_error(dirs[:1], ref[:1], [np.zeros((1, 4), bool)])["count"] == 0
    assert math.isnan(angular_error(dirs, ref, np.zeros((3, 4), bool))["mean_deg"])
    with pytest.raises(ValueError):
        angular_error(dirs, ref)  # NaN direction counted
    with pytest.raises(ValueError):
        angular_error(dirs, ref[:2])


def test_exit_directions_through_glass_sphere():
    scene = caustica.load_scene("glass-sphere")
    camera = scene.camera.with_size(65, 65)  # odd: the centre pixel looks exactly down the axis
    dirs, valid = exact_exit_directions(scene, camera)
    assert dirs.shape == (65, 65, 3) and valid.shape == (65, 65)
    assert np.array_equal(valid, region_masks(scene, camera)["refractor"])
    view = (camera.look_at - camera.position) / np.linalg.norm(camera.look_at - camera.position)
    assert valid[32, 32]
    assert angular_error(dirs[32, 32][None], view[None])["mean_deg"] < 1e-9
    # Everywhere: a ball deviates a ray with impact parameter b by 2 (asin(b / R) - asin(b / (n R))).
    origins, primary = (a[:, :, 0] for a in camera.primary_rays(1))
    b = np.linalg.norm(np.cross(origins, primary), axis=-1)[valid]  # sphere of radius 1 at the origin
    expected = np.degrees(2 * (np.arcsin(b) - np.arcsin(b / 1.5)))
    cos = np.einsum("ij,ij->i", dirs[valid], primary[valid])
    got = np.degrees(np.arctan2(np.linalg.norm(np.cross(dirs[valid], primary[valid]), axis=-1), cos))
    assert np.max(np.abs(got - expected)) < 1e-6


# -- regions --------------------------------------------------------------------


def _check_partition(masks, shape):
    assert list(masks) == list(REGIONS)
    stack = np.stack([masks[name] for name in REGIONS])
    assert stack.dtype == bool and stack.shape[1:] == shape
    assert np.all(stack.sum(axis=0) == 1)  # disjoint and covering


@pytest.mark.parametrize("spp", [1, 4])
def test_caustic_sphere_regions_partition_the_image(spp):
    scene = caustica.load_scene("caustic-sphere")
    masks = region_masks(scene, scene.camera.with_size(SIZE, SIZE), spp=spp)
    _check_partition(masks, (SIZE, SIZE))
    assert all(masks[name].any() for name in REGIONS)


def test_caustic_region_is_the_balls_shadow_on_the_floor():
    scene = caustica.load_scene("caustic-sphere")
    camera = scene.camera.with_size(SIZE, SIZE)
    masks = region_masks(scene, camera)
    # The shadow of the ball (centre (0, 1.2, 0), radius 0.6) cast by the light at (0, 4, 0) on the floor y = 0.
    shadow_radius = 4.0 * math.tan(math.asin(0.6 / 2.8))
    origins, dirs = (a[:, :, 0] for a in camera.primary_rays(1))
    t = -origins[..., 1] / np.minimum(dirs[..., 1], -1e-12)
    floor = origins + t[..., None] * dirs
    r = np.hypot(floor[..., 0], floor[..., 2])
    down = dirs[..., 1] < 0
    assert np.all(down[masks["caustic"]]) and np.all(r[masks["caustic"]] <= shadow_radius + 1e-9)
    assert np.all(masks["caustic"][down & ~masks["refractor"] & (r < shadow_radius - 1e-9)])
    # Its centroid lies on the floor under the ball, on the camera's side.
    centre = floor[masks["caustic"]].mean(axis=0)
    assert abs(centre[0]) < 0.05 and 0.0 < centre[2] < shadow_radius
    rows, cols = np.nonzero(masks["caustic"])
    ball_rows = np.nonzero(masks["refractor"])[0]
    assert abs(cols.mean() - (SIZE - 1) / 2) < 1.0 and rows.mean() > ball_rows.mean()


def test_caustic_region_leaves_out_the_pixels_partly_on_the_ball():
    """caustic_region keeps the caustic pixels whose 16 footprint rays all miss the ball (centre (0, 1.2, 0),
    radius 0.6, tested in closed form here): the Mitsuba composite lacks the glass part's light on the rest.
    The pixels it leaves out border the ball's image. The camera looks down past the ball, which hides part of
    its shadow."""
    scene = caustica.load_scene("caustic-sphere")
    camera = Camera(position=[0.0, 2.5, 2.5], look_at=[0.0, 0.4, 0.0], fov_y=40.0, size=(SIZE, SIZE))
    caustic = region_masks(scene, camera)["caustic"]
    kept = caustic_region(scene, camera)
    origins, dirs = camera.primary_rays(16)
    offset = origins - np.array([0.0, 1.2, 0.0])
    b = np.einsum("hwsj,hwsj->hws", offset, dirs)
    c = np.einsum("hwsj,hwsj->hws", offset, offset) - 0.6**2
    on_ball = ((b * b - c) > 0.0) & (b < 0.0)
    partly = on_ball.any(axis=2)
    assert np.array_equal(kept, caustic & ~partly)
    left_out = caustic & ~kept
    assert left_out.sum() >= 4
    near_ball = np.zeros_like(partly)
    ball = on_ball.all(axis=2)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            near_ball |= np.roll(np.roll(ball, dy, axis=0), dx, axis=1)
    assert np.all(near_ball[left_out])


def test_glass_sphere_refractor_is_the_projected_disc():
    scene = caustica.load_scene("glass-sphere")
    camera = scene.camera.with_size(SIZE, SIZE)
    masks = region_masks(scene, camera)
    _check_partition(masks, (SIZE, SIZE))
    assert not masks["caustic"].any()  # no lights
    # A sphere of radius 1 at distance 4 subtends asin(1/4); fov_y = 40 degrees spans SIZE pixels.
    radius_px = math.tan(math.asin(0.25)) / math.tan(math.radians(20.0)) * SIZE / 2
    area = masks["refractor"].sum()
    assert area == pytest.approx(math.pi * radius_px**2, rel=0.05)
    rows, cols = np.nonzero(masks["refractor"])
    assert abs(rows.mean() - (SIZE - 1) / 2) < 0.5 and abs(cols.mean() - (SIZE - 1) / 2) < 0.5


def test_compare_images_per_region():
    ref = _smooth_image()
    x = ref.copy()
    x[: SIZE // 2] += 0.05  # error only in the top half
    top = np.zeros((SIZE, SIZE), bool)
    top[: SIZE // 2] = True
    report = compare_images(x, ref, {"top": top, "bottom": ~top, "none": np.zeros_like(top)})
    assert list(report) == ["all", "top", "bottom", "none"]
    keys = {"psnr_linear", "psnr_srgb", "relmse", "ssim", "flip"}
    assert all(set(values) == keys for values in report.values())
    assert report["all"]["psnr_linear"] == pytest.approx(psnr_linear(x, ref))
    assert report["all"]["ssim"] == pytest.approx(ssim(x, ref))
    assert report["all"]["flip"] == pytest.approx(flip(x, ref), rel=1e-5)
    assert report["top"]["psnr_linear"] == pytest.approx(-20 * math.log10(0.05), rel=1e-9)
    assert report["top"]["flip"] == pytest.approx(flip(x, ref, top), rel=1e-9)
    assert report["top"]["ssim"] == pytest.approx(ssim(x, ref, top), rel=1e-12)
    assert report["bottom"]["relmse"] == 0.0 and report["bottom"]["psnr_srgb"] == math.inf
    assert report["top"]["flip"] > report["bottom"]["flip"]
    assert all(math.isnan(v) for v in report["none"].values())
    with pytest.raises(ValueError):
        compare_images(x, ref, {"all": top})
