"""Image files in and out: float32 linear RGB arrays (H, W, 3), row 0 at the top.

Reads OpenEXR (through the OpenEXR package), Radiance .hdr (our own RGBE
reader) and 8-bit PNG/JPEG (through Pillow, decoded from sRGB). Writes PNG
(8-bit sRGB, after exposure and a tone curve: clip or filmic), OpenEXR
(float32 linear, never tone mapped) and .hdr (flat RGBE).
Every failure is a one-line error naming the file and the fix; writes go to a
temporary file in the target directory first, so a failed write leaves nothing.
"""
from __future__ import annotations

import contextlib
import io
import os
import re
import sys
import tempfile
from pathlib import Path

import numpy as np

from .atomic import write_atomic
from .errors import EnvironmentImageError, OutputError, first_line
from .input_files import check_regular_file

READ_SUFFIXES = (".exr", ".hdr", ".png", ".jpg", ".jpeg")
MAX_READ_PIXELS = 1 << 28  # 16384 x 16384: the largest texture any GL takes; 3 GiB as float32 RGB
WRITE_SUFFIXES = (".png", ".exr")


def linear_to_srgb(x) -> np.ndarray:
    """Exact sRGB encoding curve (IEC 61966-2-1) of linear values."""
    x = np.asarray(x, dtype=np.float64)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(np.maximum(x, 0.0031308), 1.0 / 2.4) - 0.055)


def srgb_to_linear(x) -> np.ndarray:
    """Exact sRGB decoding curve: the inverse of :func:`linear_to_srgb`."""
    x = np.asarray(x, dtype=np.float64)
    return np.where(x <= 0.04045, x / 12.92, np.power((np.maximum(x, 0.04045) + 0.055) / 1.055, 2.4))


# Reading ---------------------------------------------------------------------


def check_image_path(path: Path, error: type[Exception], where: str = "") -> None:
    """``error`` in one line unless ``path`` is a regular file (links followed): not found, or what it
    is instead (a directory, a FIFO, a device), checked before anything opens it."""
    check_regular_file(path, "image", READ_SUFFIXES, error, where)


def read_image(path: str | Path, error: type[Exception] = EnvironmentImageError) -> np.ndarray:
    """Read an image as (H, W, 3) float32 linear RGB; failures raise ``error`` with one line."""
    path = Path(path)
    suffix = path.suffix.lower()
    check_image_path(path, error, " (relative paths are relative to the scene file)")
    if suffix not in READ_SUFFIXES:
        raise error(f"unsupported image format '{path.suffix}' for {path}; use one of {', '.join(READ_SUFFIXES)}")
    reader = {".exr": _read_exr, ".hdr": _read_hdr}.get(suffix, decode_8bit)
    try:
        image = reader(path)
    except Exception as exc:  # our decoders raise ValueError; OpenEXR and Pillow raise many types
        raise error(f"cannot read image {path}: {first_line(exc)}; "
                    f"check that it is a valid {suffix[1:]} file or re-export it") from None
    if image.ndim != 3 or image.shape[2] != 3 or image.size == 0:
        raise error(f"image {path} has shape {image.shape}; give an RGB image")
    return np.ascontiguousarray(image, dtype=np.float32)


def _read_exr(path: Path) -> np.ndarray:
    """R, G, B channels (or a single Y channel, replicated) of an OpenEXR file."""
    channels = _exr_channels(path)
    if all(c in channels for c in "RGB"):
        planes = [channels[c] for c in "RGB"]
    elif "Y" in channels:
        planes = [channels["Y"]] * 3
    else:
        raise ValueError(f"no R, G, B or Y channel (found {', '.join(sorted(channels)) or 'none'})")
    return np.stack([np.asarray(p, dtype=np.float32) for p in planes], axis=-1)


def read_exr_channels(path: str | Path, error: type[Exception] = EnvironmentImageError) -> dict[str, np.ndarray]:
    """Every channel of an OpenEXR file by its full name ('depth.Z', 'R'), as (H, W) arrays in their
    stored type; failures raise ``error`` with one line."""
    path = Path(path)
    check_image_path(path, error)
    try:
        return _exr_channels(path)
    except Exception as exc:  # OpenEXR raises many types
        raise error(f"cannot read image {path}: {first_line(exc)}; check that it is a valid exr file") from None


def _exr_channels(path: Path) -> dict[str, np.ndarray]:
    import OpenEXR

    failure = None
    with _library_messages() as messages:
        try:
            with OpenEXR.File(str(path), separate_channels=True) as exr:
                channels = {name: np.array(ch.pixels) for name, ch in exr.channels().items()}
        except Exception as exc:  # OpenEXR raises RuntimeError, UnicodeDecodeError, ...
            failure = first_line(exc)
    # OpenEXR prints its specific reason (or only a warning, returning what it could decode) before it raises
    if messages or failure:
        raise ValueError(_damaged_exr(messages[0] if messages else failure, path))
    return channels


def _damaged_exr(detail: str, path: Path) -> str:
    """What a damaged or truncated OpenEXR file is, in words, with OpenEXR's own reason after it."""
    detail = detail.replace(f"'{path}'", "it").replace(str(path) + ": ", "")
    detail = re.sub(r"^Warning: |\(EXR_ERR_\w+\)\s*", "", detail).strip().rstrip(".")
    if re.search(r"Unable to open|has 0 parts|missing attribute|codec can't decode", detail):
        return "it is truncated or not an OpenEXR file (its header cannot be read)"
    return f"its data is damaged or truncated ({detail[:120]})"


def _flush_c_streams() -> None:
    """fflush(NULL): C stdio (and C++ streams synced with it) buffer what they print to a file."""
    import ctypes

    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):  # no C library by that name (not glibc/musl): nothing to flush
        pass


@contextlib.contextmanager
def _library_messages():
    """Catch what a C library writes to file descriptors 1 and 2 while the block runs: yields a list that
    holds its non-empty lines afterwards (OpenEXR prints its warnings there instead of raising)."""
    lines: list[str] = []
    sys.stdout.flush()
    sys.stderr.flush()
    printed = io.StringIO()  # what the extension prints through Python's sys.stdout (pybind11's print)
    with tempfile.TemporaryFile() as caught:
        saved = {fd: os.dup(fd) for fd in (1, 2)}
        for fd in saved:
            os.dup2(caught.fileno(), fd)
        try:
            with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(printed):
                yield lines
        finally:
            _flush_c_streams()
            for fd, copy in saved.items():
                os.dup2(copy, fd)
                os.close(copy)
            caught.seek(0)
            text = caught.read().decode(errors="replace") + printed.getvalue()
            lines.extend(line for line in text.splitlines() if line.strip())


def decode_8bit(source, srgb: bool = True) -> np.ndarray:
    """PNG/JPEG (a path or a binary file object) through Pillow, decoded from sRGB to linear (``srgb``), else
    its codes scaled to [0, 1] (data such as normal or roughness maps)."""
    from PIL import Image

    with Image.open(source) as img:
        img.load()
        if img.mode in ("I;16", "I;16B", "I;16L", "I"):
            gray = np.asarray(img, dtype=np.float64) / 65535.0
            encoded = np.repeat(gray[..., None], 3, axis=-1)
        else:
            encoded = np.asarray(img.convert("RGB"), dtype=np.float64) / 255.0
    return (srgb_to_linear(encoded) if srgb else encoded).astype(np.float32)


_RESOLUTION = re.compile(rb"^([-+])Y\s+(\d+)\s+\+X\s+(\d+)\s*$")


def _read_hdr(path: Path) -> np.ndarray:
    """Radiance RGBE: header, resolution line, flat or new-style RLE scanlines."""
    data = path.read_bytes()
    if not (data.startswith(b"#?RADIANCE") or data.startswith(b"#?RGBE")):
        raise ValueError("missing '#?RADIANCE' signature")
    # Header: lines up to an empty one.
    end = data.find(b"\n\n")
    if end < 0:
        raise ValueError("header has no terminating empty line")
    for line in data[:end].split(b"\n")[1:]:
        if line.startswith(b"FORMAT=") and line.strip() != b"FORMAT=32-bit_rle_rgbe":
            raise ValueError(f"unsupported pixel format {line[7:].decode(errors='replace').strip()}")
    # Resolution line: -Y H +X W (rows top to bottom) or +Y H +X W (bottom to top).
    res_end = data.find(b"\n", end + 2)
    match = _RESOLUTION.match(data[end + 2 : res_end if res_end >= 0 else len(data)])
    if match is None:
        raise ValueError("unsupported resolution line (expected '-Y height +X width')")
    height, width = int(match.group(2)), int(match.group(3))
    if height == 0 or width == 0:
        raise ValueError("image has zero size")
    if width * height > MAX_READ_PIXELS:
        raise ValueError(f"its header says {width}x{height} pixels, above the {MAX_READ_PIXELS:,} caustica reads")
    if len(data) - res_end - 1 < 4 * height:  # even run-length rows take 4 bytes each
        raise ValueError(f"file ends before its {height} scanlines")
    rgbe = _decode_scanlines(memoryview(data)[res_end + 1 :], width, height)
    if match.group(1) == b"+":
        rgbe = rgbe[::-1]
    return rgbe_to_float(rgbe)


def _decode_scanlines(buf: memoryview, width: int, height: int) -> np.ndarray:
    """(H, W, 4) uint8 RGBE from flat or new-style run-length encoded scanlines."""
    out = np.empty((height, width, 4), dtype=np.uint8)
    pos = 0
    for row in range(height):
        head = bytes(buf[pos : pos + 4])
        is_rle = 8 <= width < 32768 and len(head) == 4 and head[0] == 2 and head[1] == 2 and not head[2] & 0x80
        if is_rle:
            if (head[2] << 8) | head[3] != width:
                raise ValueError(f"scanline {row} length does not match the image width")
            pos += 4
            for channel in range(4):
                pos = _decode_rle_channel(buf, pos, out[row, :, channel])
        else:
            count = width * 4
            if pos + count > len(buf):
                raise ValueError(f"file ends inside scanline {row}")
            out[row] = np.frombuffer(buf[pos : pos + count], dtype=np.uint8).reshape(width, 4)
            pos += count
    return out


def _decode_rle_channel(buf: memoryview, pos: int, dest: np.ndarray) -> int:
    """Decode one channel of a new-style RLE scanline into ``dest``; return the next position."""
    x, width = 0, len(dest)
    try:
        while x < width:
            code = buf[pos]
            if code > 128:  # a run: one byte repeated code - 128 times
                count = code - 128
                if x + count > width:
                    raise ValueError("run-length data overruns the scanline")
                dest[x : x + count] = buf[pos + 1]
                pos += 2
            else:  # a literal block of ``code`` bytes
                count = code
                if count == 0 or x + count > width or pos + 1 + count > len(buf):
                    raise ValueError("bad run-length literal block")
                dest[x : x + count] = np.frombuffer(buf[pos + 1 : pos + 1 + count], dtype=np.uint8)
                pos += 1 + count
            x += count
    except IndexError:
        raise ValueError("file ends inside run-length data") from None
    return pos


def rgbe_to_float(rgbe: np.ndarray) -> np.ndarray:
    """(..., 4) uint8 RGBE to (..., 3) float32: mantissa * 2**(exponent - 136), exponent 0 is black.

    As Mitsuba, stb_image and OpenEXR's tools decode it (no half-step offset, so black stays black)."""
    exponent = rgbe[..., 3].astype(np.int32)
    scale = np.where(exponent > 0, np.ldexp(1.0, exponent - 136), 0.0)
    return (rgbe[..., :3].astype(np.float64) * scale[..., None]).astype(np.float32)


def float_to_rgbe(rgb: np.ndarray) -> np.ndarray:
    """(..., 3) non-negative floats to (..., 4) uint8 RGBE, the inverse of :func:`rgbe_to_float`: each
    mantissa rounded to the nearest step (error at most half a step of the brightest channel); values
    too small for the shared exponent become black."""
    rgb = np.maximum(np.asarray(rgb, dtype=np.float64), 0.0)
    brightest = rgb.max(axis=-1)
    # Exponent e puts the brightest mantissa in [128, 256): brightest = f * 2**x with f in [0.5, 1), e = x + 128.
    _, x = np.frexp(brightest)
    exponent = np.where(np.rint(np.ldexp(brightest, 8 - x)) >= 256, x + 129, x + 128)  # rounded up to 256: next one
    visible = (brightest > 0) & (exponent >= 1)
    exponent = np.minimum(exponent, 255)
    step = np.ldexp(1.0, exponent - 136)
    out = np.zeros(rgb.shape[:-1] + (4,), dtype=np.uint8)
    mantissa = np.clip(np.rint(rgb / step[..., None]), 0, 255)
    out[..., :3] = np.where(visible[..., None], mantissa, 0)
    out[..., 3] = np.where(visible, exponent, 0)
    return out


# Writing ---------------------------------------------------------------------


TONEMAPS = ("clip", "filmic")  # PNG tone curves; "clip" is the default and today's encoding

# "filmic": Krzysztof Narkowicz's fit of the ACES reference rendering + output transforms,
# f(x) = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14)
# ("ACES Filmic Tone Mapping Curve", 2016, https://knarkowicz.wordpress.com/2016/01/06/aces-filmic-tone-mapping-curve/).
# Two changes, both scalings: his f tends to 2.51 / 2.43 > 1 and so clips (his shader saturates it) at
# x ~ 7.2; divided by that asymptote it approaches 1 and never reaches it. His post pre-scales the input
# (by 0.6) to pick the exposure; we pick the pre-scale that keeps mid-grey 0.18 at 0.18 exactly, so the
# filmic and clip PNGs of a mid-grey pixel are the same 8-bit code. f' has numerator
# (ad - bc) x^2 + 2ae x + be > 0 (a, b, c, d, e the five constants), so the curve is strictly increasing.
ACES_FIT = (2.51, 0.03, 2.43, 0.59, 0.14)
FILMIC_MID_GREY = 0.18


def _aces(y):
    a, b, c, d, e = ACES_FIT
    return y * (a * y + b) / (y * (c * y + d) + e) * (c / a)


def _mid_grey_scale() -> float:
    """s with _aces(s * 0.18) = 0.18: the positive root of a quadratic in y = s * 0.18."""
    a, b, c, d, e = ACES_FIT
    t = FILMIC_MID_GREY * a / c  # _aces(y) = 0.18 <=> y (a y + b) = t (y (c y + d) + e)
    qa, qb, qc = a - t * c, b - t * d, -t * e
    return (-qb + np.sqrt(qb * qb - 4.0 * qa * qc)) / (2.0 * qa) / FILMIC_MID_GREY


FILMIC_INPUT_SCALE = _mid_grey_scale()  # about 0.7415
_FILMIC_INPUT_MAX = 1e30  # _aces is 1.0 in float64 long before; keeps y * y finite for any exposure


def filmic(x) -> np.ndarray:
    """The "filmic" tone curve of linear radiance: 0 at 0, 0.18 at 0.18, strictly increasing, tends to 1.

    Negative input is treated as 0. The result stays below 1 in float64 up to about 1e15; as an 8-bit
    sRGB code it reaches 254 at about 23 and 255 at about 70 (clip: 255 from 1 on)."""
    y = np.minimum(np.maximum(np.asarray(x, dtype=np.float64), 0.0) * FILMIC_INPUT_SCALE, _FILMIC_INPUT_MAX)
    return _aces(y)


def tone_map(image, exposure: float = 0.0, tonemap: str = "clip") -> np.ndarray:
    """Linear radiance to display values in [0, 1], before the sRGB encoding: image * 2**exposure, then
    clipped to [0, 1] ("clip") or through :func:`filmic` ("filmic")."""
    if tonemap not in TONEMAPS:
        raise OutputError(f"unknown tonemap '{tonemap}'; use one of {', '.join(TONEMAPS)}")
    exposed = image * 2.0 ** float(exposure)
    return np.clip(exposed, 0.0, 1.0) if tonemap == "clip" else filmic(exposed)


def to_srgb8(image, exposure: float = 0.0, tonemap: str = "clip") -> np.ndarray:
    """(H, W, 3) uint8 sRGB of a linear image, as :func:`write_image` writes PNGs."""
    return np.round(linear_to_srgb(tone_map(image, exposure, tonemap)) * 255.0).astype(np.uint8)


def write_image(path: str | Path, image: np.ndarray, exposure: float = 0.0, tonemap: str = "clip") -> Path:
    """Write .png (8-bit sRGB of image * 2**exposure, clipped or through the filmic curve: ``tonemap``)
    or .exr (float32 linear; exposure and tonemap do not apply)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in WRITE_SUFFIXES:
        raise OutputError(f"unsupported output format '{path.suffix}' for {path}; use .png or .exr")
    if tonemap not in TONEMAPS:
        raise OutputError(f"unknown tonemap '{tonemap}' for {path}; use one of {', '.join(TONEMAPS)}")
    image = _checked_image(image, path)
    if suffix == ".png":
        pixels = to_srgb8(image, exposure, tonemap)
        return write_atomic(path, lambda tmp: _write_png(tmp, pixels))
    return write_atomic(path, lambda tmp: _write_exr(tmp, image))


def write_hdr(path: str | Path, image: np.ndarray) -> Path:
    """Write a Radiance .hdr with flat (uncompressed) RGBE scanlines."""
    path = Path(path)
    image = _checked_image(image, path)
    height, width = image.shape[:2]
    header = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n".encode()
    payload = header + float_to_rgbe(image).tobytes()
    return write_atomic(path, lambda tmp: Path(tmp).write_bytes(payload))


def _checked_image(image, path: Path) -> np.ndarray:
    """The image as float32 (H, W, 3), or OutputError when it is not finite RGB."""
    arr = np.asarray(image)
    if arr.ndim != 3 or arr.shape[2] != 3 or arr.shape[0] == 0 or arr.shape[1] == 0:
        raise OutputError(f"cannot write {path}: image has shape {arr.shape}; expected (height, width, 3) RGB")
    arr = arr.astype(np.float32)
    if not np.all(np.isfinite(arr)):
        raise OutputError(f"cannot write {path}: image holds NaN or infinite values; fix the render first")
    return arr


def _write_png(tmp: str, pixels: np.ndarray) -> None:
    from PIL import Image

    Image.fromarray(pixels).save(tmp, format="PNG")


def write_exr_channels(path: str | Path, channels: dict[str, np.ndarray]) -> Path:
    """Write one OpenEXR (ZIP compressed, atomically) of named (H, W) float32 or uint32 channels, e.g.
    {'depth.Z': ..., 'normal.X': ...}: a multi-layer file, each layer's channels 'layer.suffix'."""
    planes = {name: np.ascontiguousarray(p) for name, p in channels.items()}
    return write_atomic(Path(path), lambda tmp: _write_exr_planes(tmp, planes))


def _write_exr(tmp: str, image: np.ndarray) -> None:
    _write_exr_planes(tmp, {"RGB": np.ascontiguousarray(image, dtype=np.float32)})


def _write_exr_planes(tmp: str, planes: dict) -> None:
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, planes) as exr:
        exr.write(tmp)
