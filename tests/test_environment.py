"""The equirectangular convention (Mitsuba's): where each direction lands, texel by texel."""
import numpy as np
import pytest

from caustica.scene.environment import Environment, direction_to_uv, procedural_environment, uv_to_direction


def unique_texels(h: int, w: int) -> np.ndarray:
    """An image whose texel (row j, column i) holds j * w + i in every channel (and a channel offset)."""
    index = np.arange(h * w, dtype=np.float32).reshape(h, w)
    return np.stack([index, index + 0.25, index + 0.5], axis=-1)


@pytest.mark.parametrize("direction, uv", [
    ((0.0, 0.0, -1.0), (0.0, 0.5)),
    ((1.0, 0.0, 0.0), (0.25, 0.5)),
    ((0.0, 0.0, 1.0), (0.5, 0.5)),
    ((-1.0, 0.0, 0.0), (0.75, 0.5)),
])
def test_horizon_directions(direction, uv):
    np.testing.assert_allclose(direction_to_uv(np.array(direction)), uv, atol=1e-12)


def test_poles():
    assert direction_to_uv(np.array([0.0, 1.0, 0.0]))[1] == 0.0
    assert direction_to_uv(np.array([0.0, -1.0, 0.0]))[1] == pytest.approx(1.0)


def test_uv_round_trip():
    rng = np.random.default_rng(1)
    uv = np.stack([rng.uniform(0, 1, 1000), rng.uniform(0.01, 0.99, 1000)], axis=-1)
    d = uv_to_direction(uv)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0)
    np.testing.assert_allclose(direction_to_uv(d), uv, atol=1e-12)


def test_lookup_returns_each_texel_at_its_own_sample_position():
    """Column i is sampled at u = (i + 0.5) / W (x = u W - 0.5), row j at v = j / (H - 1)."""
    h, w = 9, 16
    image = unique_texels(h, w)
    env = Environment(image, source="test")
    rows, cols = np.meshgrid(np.arange(1, h - 1), np.arange(w), indexing="ij")  # pole rows collapse to a point
    uv = np.stack([(cols + 0.5) / w, rows / (h - 1)], axis=-1)
    values = env.lookup(uv_to_direction(uv))
    np.testing.assert_allclose(values, image[rows, cols], atol=1e-3)


def test_minus_z_falls_between_the_last_and_first_column():
    h, w = 9, 16
    image = unique_texels(h, w)
    value = Environment(image, source="test").lookup(np.array([0.0, 0.0, -1.0]))
    middle = (h - 1) // 2
    np.testing.assert_allclose(value, (image[middle, w - 1] + image[middle, 0]) / 2, atol=1e-3)


def test_up_reads_row_zero_and_down_the_last_row():
    image = np.zeros((8, 16, 3), np.float32)
    image[0] = 2.0
    image[-1] = 5.0
    env = Environment(image, source="test")
    np.testing.assert_allclose(env.lookup(np.array([0.0, 1.0, 0.0])), 2.0)
    np.testing.assert_allclose(env.lookup(np.array([0.0, -1.0, 0.0])), 5.0)


def test_white_environment_irradiance_is_pi():
    env = procedural_environment("white")
    rng = np.random.default_rng(2)
    normals = rng.normal(size=(50, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.concatenate([normals, np.eye(3), -np.eye(3)])
    np.testing.assert_allclose(env.irradiance(normals), np.pi, rtol=0.01)


def test_environment_rejects_bad_images():
    from caustica.errors import EnvironmentImageError

    with pytest.raises(EnvironmentImageError):
        Environment(np.zeros((4, 4)), source="test")
    with pytest.raises(EnvironmentImageError, match="NaN"):
        Environment(np.full((4, 4, 3), np.nan), source="test")
