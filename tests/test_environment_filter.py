"""Environment lookups filtered over the pixel footprint (common/environment.glsl): a pixel shows the
mean of the environment over the directions it covers, as a box-filtered (supersampled) image does,
not one point of it."""
from __future__ import annotations

import numpy as np
import pytest

from caustica import Renderer
from caustica.metrics.images import psnr_linear
from caustica.scene import Camera, Glass, Mirror, Scene, SceneObject, Transform
from caustica.scene.environment import Environment, procedural_environment
from caustica.scene.shapes import sphere


def stripes(width: int = 2048, height: int = 64) -> Environment:
    """Columns alternately 0 and 1: over any footprint of many texels the mean is 1/2."""
    image = np.zeros((height, width, 3), np.float32)
    image[:, ::2] = 1.0
    return Environment(image, source="test:stripes")


def empty_scene(environment: Environment, size=(64, 48), fov_y=60.0, look=(0.0, 0.0, -1.0)) -> Scene:
    camera = Camera(position=[0.0, 0.0, 0.0], look_at=list(look), fov_y=fov_y, size=size)
    return Scene(camera=camera, objects=[], lights=[], environment=environment)


def test_minified_stripes_average_to_one_half():
    """About 10 texels a pixel across the horizon: every pixel is near 1/2, no moire of 0s and 1s."""
    with Renderer((64, 48)) as renderer:
        image = renderer.render(empty_scene(stripes()), "plain", 1)
    middle = image[12:36, :, 0]  # away from the poles' squeeze
    assert abs(float(middle.mean()) - 0.5) < 0.02
    assert float(np.abs(middle - 0.5).max()) < 0.1


def test_the_seam_where_u_wraps_is_not_blurred():
    """Looking down -Z puts u = 0 = 1 mid-image: a smooth environment stays smooth there (implicit
    derivatives of u would jump by 1 and blur the whole texture into the seam's column)."""
    h, w = 64, 256
    columns = np.cos(2 * np.pi * (np.arange(w) + 0.5) / w)  # periodic, no edge at the seam
    image = np.repeat(np.repeat(columns[None, :, None], h, axis=0), 3, axis=2).astype(np.float32) + 1.5
    env = Environment(image, source="test:cosine")
    with Renderer((64, 48)) as renderer:
        out = renderer.render(empty_scene(env, fov_y=20.0), "plain", 1)[..., 0]
    row = out[24]
    assert float(np.abs(np.diff(row)).max()) < 0.02  # no column stands out at the seam
    assert abs(float(row[32]) - 2.5) < 0.02  # and it keeps the texture's value there (cos 0 = 1)


@pytest.mark.parametrize("material, radius, distance, floor_db",
                         [(Glass(ior=1.5), 1.0, 3.6, 35.5), (Mirror(), 1.0, 3.6, 32.0), (Mirror(), 0.4, 4.0, 28.0)],
                         ids=["glass", "mirror", "small-mirror"])
def test_one_sample_is_closer_to_the_box_filter_than_point_lookups(material, radius, distance, floor_db):
    """A ball minifies the environment it refracts or reflects; at 1 spp its image must be within
    ``floor_db`` of the 64 spp image (the ball fills the same share of the frame at every size).
    Measured: point lookups 31.9 (glass) and 25.7 dB (mirror); footprints left out past the
    discontinuity cap 34.9, 30.7 and, on the small mirror ball, whose reflection magnifies past the
    cap almost everywhere, 25.6 dB; footprints shortened to the cap 36.4, 33.2 and 29.0 dB."""
    ball = SceneObject("ball", sphere(radius, 5), material, Transform())
    camera = Camera(position=[0.0, 0.3 * distance / 3.6, distance], look_at=[0.0, 0.0, 0.0],
                    fov_y=40.0 * radius * 3.6 / distance, size=(96, 96))
    scene = Scene(camera=camera, objects=[ball], lights=[], environment=procedural_environment("sky-checker"))
    with Renderer((96, 96)) as renderer:
        reference = renderer.render(scene, "env-map", 64)
        one = renderer.render(scene, "env-map", 1)
    assert psnr_linear(one, reference) >= floor_db


def test_filter_is_chosen_in_a_scene_file_and_checked():
    import caustica
    from caustica.errors import EnvironmentImageError

    base = {"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]}, "objects": []}
    assert caustica.scene_from_dict(base).environment.filter == "footprint"
    point = caustica.scene_from_dict({**base, "environment": {"procedural": "white", "filter": "bilinear"}})
    assert point.environment.filter == "bilinear"
    assert point.environment.rotated(30.0).filter == "bilinear"  # derived environments keep it
    with pytest.raises(EnvironmentImageError, match="filter 'nearest' is unknown; choose one of footprint, bilinear"):
        caustica.scene_from_dict({**base, "environment": {"filter": "nearest"}})


def test_bilinear_and_footprint_textures_are_kept_apart():
    """One image, both filters in one renderer: each render gets its own texture (the cache keys on
    the filter), so the second does not reuse the first's mip levels or lack of them."""
    scene = empty_scene(stripes())
    with Renderer((64, 48)) as renderer:
        filtered = renderer.render(scene, "plain", 1)
        scene.environment.filter = "bilinear"
        point = renderer.render(scene, "plain", 1)
    assert np.abs(point[12:36, :, 0] - 0.5).max() > 0.3  # point samples alias: 0s and 1s
    assert np.abs(filtered[12:36, :, 0] - 0.5).max() < 0.1
