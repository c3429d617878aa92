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


# Tone mapping (PNG only) ---------------------------------------------------------


def _clip_png_before_tonemap(image, exposure=0.0) -> np.ndarray:
    """The PNG encoding as it was before the tonemap option: the "clip" mode must stay bit-identical."""
    encoded = linear_to_srgb(np.clip(image * 2.0 ** float(exposure), 0.0, 1.0))
    return np.round(encoded * 255.0).astype(np.uint8)


def _png_codes(tmp_path, image, **options) -> np.ndarray:
    from PIL import Image

    path = write_image(tmp_path / "t.png", image, **options)
    with Image.open(path) as img:
        return np.asarray(img.convert("RGB"))


def _row(values) -> np.ndarray:
    return np.repeat(np.asarray(values, np.float32)[None, :, None], 3, axis=2)


def test_filmic_curve_known_values_and_monotone():
    from caustica.images import FILMIC_INPUT_SCALE, filmic

    assert filmic(0.0) == 0.0 and filmic(-3.0) == 0.0
    assert filmic(0.18) == pytest.approx(0.18, abs=1e-12)  # mid-grey kept (the pre-scale is solved for it)
    assert FILMIC_INPUT_SCALE == pytest.approx(0.74152, abs=1e-5)
    # Narkowicz's ACES fit, divided by its asymptote 2.51 / 2.43, at x = 1 (by hand: y = 0.74152).
    y = 0.7415168381421822
    assert filmic(1.0) == pytest.approx(y * (2.51 * y + 0.03) / (y * (2.43 * y + 0.59) + 0.14) * 2.43 / 2.51, rel=1e-12)
    x = np.linspace(0.0, 1e4, 2_000_001)
    f = filmic(x)
    assert np.all(np.diff(f) > 0)  # strictly increasing over [0, 1e4]
    assert f.max() < 1.0 and f[-1] > 0.99996  # approaches 1, never reaches it
    assert filmic(1e14) < 1.0 and filmic(1e300) == 1.0  # huge inputs are 1, not NaN


def test_filmic_png_reaches_255_only_for_very_large_values(tmp_path):
    from caustica.images import to_srgb8

    x = np.geomspace(1e-4, 1e4, 200_001)
    codes = to_srgb8(_row(x), tonemap="filmic")[0, :, 0]
    assert np.all(np.diff(codes.astype(int)) >= 0)
    assert codes[x < 60.0].max() <= 254 and codes[x < 20.0].max() <= 253
    assert x[np.argmax(codes == 255)] == pytest.approx(69.9, abs=0.2)  # clip: 255 from x = 1 on
    assert to_srgb8(_row([0.0]), tonemap="filmic").max() == 0


def test_bright_caustic_keeps_gradient_where_clip_saturates(tmp_path):
    caustic = _row(np.linspace(1.0, 20.0, 200))  # a caustic peaking at 20x white
    clip = _png_codes(tmp_path, caustic)
    filmic = _png_codes(tmp_path, caustic, tonemap="filmic")
    assert np.unique(clip).tolist() == [255]  # a white blot
    assert len(np.unique(filmic)) >= 25 and filmic.min() == 219 and filmic.max() == 253  # 27 codes, 1x to 20x white
    assert np.all(np.diff(filmic[0, :, 0].astype(int)) >= 0)


def test_filmic_mid_grey_within_one_code_of_clip(tmp_path):
    """Stated tolerance: mid-grey 0.18 (and 0.5) within one 8-bit code of clip's value, at any exposure."""
    for exposure in (-2.0, 0.0, 1.5):
        grey = _row([0.18 * 2.0 ** -exposure, 0.5 * 2.0 ** -exposure])
        clip = _png_codes(tmp_path, grey, exposure=exposure).astype(int)
        filmic = _png_codes(tmp_path, grey, exposure=exposure, tonemap="filmic").astype(int)
        assert clip[0, 0, 0] == 118
        assert np.abs(filmic - clip).max() <= 1, (exposure, clip, filmic)


def test_clip_mode_is_bit_identical_to_before(tmp_path):
    rng = np.random.default_rng(7)
    image = (rng.lognormal(-1.0, 1.5, (16, 24, 3)) * rng.choice([0.0, 1.0], (16, 24, 1))).astype(np.float32)
    for exposure in (0.0, -1.0, 2.5):
        expected = _clip_png_before_tonemap(image, exposure)
        np.testing.assert_array_equal(_png_codes(tmp_path, image, exposure=exposure), expected)
        np.testing.assert_array_equal(_png_codes(tmp_path, image, exposure=exposure, tonemap="clip"), expected)


def test_exr_ignores_tonemap_and_exposure(tmp_path):
    image = gradient() * 50.0
    written = [write_image(tmp_path / f"{mode}.exr", image, exposure=2.0, tonemap=mode) for mode in ("clip", "filmic")]
    for path in written:
        np.testing.assert_array_equal(read_image(path), image)
    assert written[0].read_bytes() == written[1].read_bytes()


def test_unknown_tonemap_is_one_line_and_writes_nothing(tmp_path):
    with pytest.raises(OutputError, match="unknown tonemap 'aces'.*use one of clip, filmic"):
        write_image(tmp_path / "t.png", gradient(), tonemap="aces")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("keep", [20, 200, 300, 360, -8])
def test_truncated_exr_is_one_clean_error_and_prints_nothing(tmp_path, capfd, keep):
    """OpenEXR prints its reasons on stdout/stderr and, for damaged pixel data, may only warn: every cut of a
    valid file must be an EnvironmentImageError in words, with nothing reaching the terminal."""
    whole = tmp_path / "whole.exr"
    write_image(whole, np.full((8, 8, 3), 0.5, np.float32))
    data = whole.read_bytes()
    cut = tmp_path / "cut.exr"
    cut.write_bytes(data[:keep])
    capfd.readouterr()
    with pytest.raises(EnvironmentImageError, match=r"cut\.exr: it(s data)? is (damaged or )?truncated") as err:
        read_image(cut)
    assert "part index" not in str(err.value) and "EXR_ERR" not in str(err.value)
    printed = capfd.readouterr()
    assert printed.out == "" and printed.err == ""
