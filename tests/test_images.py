"""Image I/O: exact sRGB curves, round trips through PNG/EXR/HDR, one-line errors, atomic writes."""
import numpy as np
import pytest

from caustica.errors import EnvironmentImageError, OutputError, SceneError
from caustica.images import linear_to_srgb, read_image, srgb_to_linear, write_hdr, write_image


def gradient(h=6, w=10) -> np.ndarray:
    rng = np.random.default_rng(0)
    return rng.uniform(0.0, 1.0, (h, w, 3)).astype(np.float32)


def test_srgb_curve_values():
    assert linear_to_srgb(0.0) == 0.0
    assert linear_to_srgb(1.0) == pytest.approx(1.0, abs=1e-12)
    assert srgb_to_linear(1.0) == pytest.approx(1.0, abs=1e-12)
    # Both pieces meet at the linear 0.0031308 / encoded 0.04045 boundary.
    assert linear_to_srgb(0.0031308) == pytest.approx(12.92 * 0.0031308)
    assert 1.055 * 0.0031308 ** (1 / 2.4) - 0.055 == pytest.approx(12.92 * 0.0031308, abs=1e-7)
    assert srgb_to_linear(0.04045) == pytest.approx(0.04045 / 12.92)
    assert linear_to_srgb(0.5) == pytest.approx(0.7353569830524495)
    assert srgb_to_linear(0.5) == pytest.approx(0.21404114048223255)
    assert linear_to_srgb(0.18) == pytest.approx(0.46135612950044164)


def test_srgb_round_trip_and_monotone():
    x = np.linspace(0.0, 1.0, 10001)
    np.testing.assert_allclose(srgb_to_linear(linear_to_srgb(x)), x, atol=1e-12)
    np.testing.assert_allclose(linear_to_srgb(srgb_to_linear(x)), x, atol=1e-12)
    assert np.all(np.diff(linear_to_srgb(x)) > 0)


def test_png_round_trip_within_one_code(tmp_path):
    image = gradient()
    write_image(tmp_path / "a.png", image)
    back = read_image(tmp_path / "a.png")
    assert back.dtype == np.float32 and back.shape == image.shape
    np.testing.assert_allclose(linear_to_srgb(back), linear_to_srgb(image), atol=0.5 / 255 + 1e-6)


def test_png_exposure_and_clipping(tmp_path):
    image = np.full((2, 2, 3), 0.25, np.float32)
    image[0, 0] = 7.0
    write_image(tmp_path / "e.png", image, exposure=1.0)
    back = read_image(tmp_path / "e.png")
    np.testing.assert_allclose(back[1, 1], 0.5, atol=0.005)
    np.testing.assert_allclose(back[0, 0], 1.0)


def test_exr_round_trip_is_exact(tmp_path):
    image = gradient() * 100.0
    write_image(tmp_path / "a.exr", image)
    np.testing.assert_array_equal(read_image(tmp_path / "a.exr"), image)


def test_exr_half_and_luminance_channels(tmp_path):
    import OpenEXR

    y = np.arange(12, dtype=np.float16).reshape(3, 4)
    header = {"compression": OpenEXR.NO_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"Y": y}) as exr:
        exr.write(str(tmp_path / "y.exr"))
    back = read_image(tmp_path / "y.exr")
    assert back.shape == (3, 4, 3)
    for c in range(3):
        np.testing.assert_array_equal(back[..., c], y.astype(np.float32))


def test_hdr_round_trip_within_rgbe_precision(tmp_path):
    image = gradient() * np.array([1.0, 10.0, 1000.0], np.float32)
    image[0, 0] = 0.0
    write_hdr(tmp_path / "a.hdr", image)
    back = read_image(tmp_path / "a.hdr")
    assert back.shape == image.shape
    brightest = image.max(axis=-1, keepdims=True)
    assert np.all(np.abs(back - image) <= brightest / 128 + 1e-30)
    np.testing.assert_array_equal(back[0, 0], 0.0)


def rle_channel(values: bytes) -> bytes:
    """New-style RLE of one channel: runs of 4+ equal bytes as runs, the rest as literals."""
    out, i = bytearray(), 0
    while i < len(values):
        j = i
        while j < len(values) and values[j] == values[i] and j - i < 127:
            j += 1
        if j - i >= 4:
            out += bytes([128 + j - i, values[i]])
            i = j
        else:
            k = min(i + 4, len(values))
            out += bytes([k - i]) + values[i:k]
            i = k
    return bytes(out)


def test_hdr_reads_run_length_encoded_scanlines(tmp_path):
    height, width = 3, 16
    rgbe = np.zeros((height, width, 4), np.uint8)
    rgbe[..., 3] = 129  # 2**(129-136) * m
    rgbe[:, :8, 0] = 200  # a run
    rgbe[:, :, 1] = np.arange(width) * 10  # literals
    rgbe[1, :, 2] = 77
    body = bytearray()
    for row in rgbe:
        body += bytes([2, 2, width >> 8, width & 255])
        for c in range(4):
            body += rle_channel(row[:, c].tobytes())
    header = f"#?RADIANCE\n# made by a test\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1.0\n\n-Y {height} +X {width}\n".encode()
    (tmp_path / "rle.hdr").write_bytes(header + bytes(body))
    back = read_image(tmp_path / "rle.hdr")
    expected = rgbe[..., :3].astype(np.float64) * 2.0 ** (129 - 136)
    np.testing.assert_allclose(back, expected, rtol=1e-7)


def test_hdr_decodes_as_mitsuba_and_stb_image():
    # value = mantissa * 2**(exponent - 136), no half-step offset: 128 * 2**-7 is exactly 1, zero stays zero.
    from caustica.images import rgbe_to_float

    pixels = np.array([[0, 128, 0, 129], [255, 1, 0, 136], [200, 200, 200, 0]], np.uint8)
    np.testing.assert_array_equal(rgbe_to_float(pixels), np.array([[0, 1, 0], [255, 1, 0], [0, 0, 0]], np.float32))


def test_hdr_encoding_is_the_exact_inverse_of_decoding():
    from caustica.images import float_to_rgbe, rgbe_to_float

    rng = np.random.default_rng(3)
    rgbe = rng.integers(0, 256, (500, 4)).astype(np.uint8)
    rgbe[:, 0] = np.maximum(rgbe[:, 0], 128)  # a normalized pixel: its brightest mantissa in [128, 256)
    rgbe[:, 3] = rng.integers(1, 256, 500)
    np.testing.assert_array_equal(float_to_rgbe(rgbe_to_float(rgbe)), rgbe)
    # Floats round to the nearest step (half a step of the brightest channel at most), 255.9/256 up to 1.
    values = rng.random((500, 3)) * np.exp(rng.normal(0.0, 8.0, (500, 1)))
    error = np.abs(rgbe_to_float(float_to_rgbe(values)) - values) / values.max(axis=-1, keepdims=True)
    assert error.max() <= 1.0 / 256 + 1e-12
    np.testing.assert_array_equal(float_to_rgbe(np.array([255.9 / 256, 0.0, 0.0])), [128, 0, 0, 129])


def test_hdr_bottom_up_orientation(tmp_path):
    image = np.zeros((2, 3, 3), np.float32)
    image[0] = 1.0  # the top row is bright
    write_hdr(tmp_path / "a.hdr", image)
    data = (tmp_path / "a.hdr").read_bytes().replace(b"-Y 2 +X 3", b"+Y 2 +X 3")
    (tmp_path / "b.hdr").write_bytes(data)
    back = read_image(tmp_path / "b.hdr")
    assert back[1].min() > 0.9 and back[0].max() == 0.0


@pytest.mark.parametrize("name, content", [
    ("broken.exr", b"definitely not an exr file"),
    ("broken.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 4\n\x01\x02"),
    ("noheader.hdr", b"P6 this is not radiance"),
    ("broken.png", b"\x89PNG\r\n\x1a\n garbage"),
    ("broken.jpg", b"\xff\xd8\xff garbage"),
])
def test_corrupt_images_give_one_line(tmp_path, name, content):
    (tmp_path / name).write_bytes(content)
    with pytest.raises(EnvironmentImageError) as info:
        read_image(tmp_path / name)
    message = str(info.value)
    assert name in message and "\n" not in message
    assert info.value.__cause__ is None and info.value.__suppress_context__


def test_read_errors_missing_and_unknown_suffix(tmp_path):
    with pytest.raises(EnvironmentImageError, match="not found"):
        read_image(tmp_path / "nope.exr")
    (tmp_path / "a.tga").write_bytes(b"x")
    with pytest.raises(EnvironmentImageError, match="unsupported image format '.tga'"):
        read_image(tmp_path / "a.tga")
    with pytest.raises(SceneError):  # the error type is the caller's choice
        read_image(tmp_path / "nope.png", error=SceneError)


def test_write_into_missing_directory_leaves_nothing(tmp_path):
    target = tmp_path / "missing" / "out.png"
    with pytest.raises(OutputError) as info:
        write_image(target, gradient())
    assert str(info.value) == f"output directory {tmp_path / 'missing'} does not exist; create it first"
    assert not (tmp_path / "missing").exists()


@pytest.mark.parametrize("image, match", [
    (np.zeros((4, 4)), "shape"),
    (np.zeros((4, 4, 4)), "shape"),
    (np.full((2, 2, 3), np.nan), "NaN"),
    (np.full((2, 2, 3), np.inf), "NaN or infinite"),
])
def test_write_rejects_bad_images_and_leaves_nothing(tmp_path, image, match):
    with pytest.raises(OutputError, match=match):
        write_image(tmp_path / "out.exr", image)
    assert list(tmp_path.iterdir()) == []


def test_write_rejects_unknown_suffix(tmp_path):
    with pytest.raises(OutputError, match="use .png or .exr"):
        write_image(tmp_path / "out.jpg", gradient())
    assert list(tmp_path.iterdir()) == []


def test_failed_write_removes_temp_and_keeps_old_file(tmp_path, monkeypatch):
    import caustica.images as images

    target = tmp_path / "out.exr"
    write_image(target, gradient())
    before = target.read_bytes()

    def fail(tmp, image):
        with open(tmp, "wb") as f:
            f.write(b"half")
        raise RuntimeError("disk full")

    monkeypatch.setattr(images, "_write_exr", fail)
    with pytest.raises(OutputError, match="disk full"):
        write_image(target, gradient())
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["out.exr"]
