"""Camera conventions: projection matrices round-trip, primary rays agree with the raster projection."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.scene import Camera, fov_x_from_fov_y, fov_y_from_fov_x
from caustica.scene.transform import orthographic_clip_from_view, perspective_clip_from_view


def test_perspective_round_trip_and_depth_range():
    clip_from_view = perspective_clip_from_view(50.0, 1.5, 0.1, 20.0)
    points = np.array([[0.3, -0.2, -0.1, 1.0], [1.0, 2.0, -20.0, 1.0], [-0.5, 0.1, -3.0, 1.0]])
    clip = points @ clip_from_view.T
    back = clip @ np.linalg.inv(clip_from_view).T
    np.testing.assert_allclose(back / back[:, 3:], points, atol=1e-9)
    ndc_z = clip[:, 2] / clip[:, 3]
    assert ndc_z[0] == pytest.approx(-1.0) and ndc_z[1] == pytest.approx(1.0)


def test_orthographic_round_trip():
    clip_from_view = orthographic_clip_from_view(2.0, 3.0, 0.5, 10.0)
    p = np.array([1.0, -2.0, -4.0, 1.0])
    np.testing.assert_allclose(np.linalg.inv(clip_from_view) @ (clip_from_view @ p), p, atol=1e-12)
    assert (clip_from_view @ np.array([2.0, 3.0, -0.5, 1.0]))[:3] == pytest.approx([1.0, 1.0, -1.0])


def test_view_matrix_looks_down_negative_z():
    camera = Camera(position=[1.0, 2.0, 3.0], look_at=[1.0, 2.0, -5.0])
    view = camera.view_from_world()
    assert (view @ np.array([1.0, 2.0, -5.0, 1.0]))[:3] == pytest.approx([0.0, 0.0, -8.0])
    assert (view @ np.array([1.0, 3.0, 3.0, 1.0]))[:3] == pytest.approx([0.0, 1.0, 0.0])


def test_fov_conversions_invert():
    assert fov_y_from_fov_x(fov_x_from_fov_y(35.0, 640, 480), 640, 480) == pytest.approx(35.0)
    assert fov_y_from_fov_x(40.0, 512, 512) == pytest.approx(40.0)


def test_primary_rays_hit_their_pixel_centres():
    """A point along the ray of pixel (row, col) projects to that pixel's centre, row 0 at the top."""
    camera = Camera(position=[0.5, 1.0, 4.0], look_at=[0.0, 0.2, 0.0], fov_y=45.0, size=(64, 48))
    origins, dirs = camera.primary_rays()
    clip_from_world = camera.clip_from_world()
    for row, col in [(0, 0), (47, 63), (10, 30), (24, 32)]:
        p = np.append(origins[row, col, 0] + 3.0 * dirs[row, col, 0], 1.0)
        clip = clip_from_world @ p
        x_pixel = (clip[0] / clip[3] * 0.5 + 0.5) * 64
        y_pixel_from_top = (0.5 - clip[1] / clip[3] * 0.5) * 48
        assert x_pixel == pytest.approx(col + 0.5, abs=1e-6)
        assert y_pixel_from_top == pytest.approx(row + 0.5, abs=1e-6)


def test_supersampled_rays_are_stratified_inside_the_pixel():
    camera = Camera(size=(8, 8))
    _, dirs = camera.primary_rays(spp=4)
    assert dirs.shape == (8, 8, 4, 3)
    assert len(np.unique(np.round(dirs[3, 3], 9), axis=0)) == 4
