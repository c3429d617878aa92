"""The rules a scene's numbers obey, in one place: the TOML loader and :meth:`Scene.validate` both use them.

Pure data, no GL. Each check raises :class:`SceneError` (or the subclass given as ``error``) with one
line that names the value, shows it (cut to a few dozen characters) and states the range. The ranges
are plausible rather than physical limits; they keep every product the renderer forms (a
coordinate times a scale, an intensity times a colour, near / far in the depth buffer) far inside
float32, so a bad number fails here instead of as a NaN image:

- lengths and coordinates: |x| <= 1e6 scene units after the object's transform, scales in [1e-6, 1e6];
- the camera's near plane at least 1e-6, far / near at most 1e7 (depth precision);
- rotations within +-1e6 degrees;
- IOR in [0.1, 10] per channel (glass 1.5, diamond 2.42; below 1 for an air bubble in water);
- intensities (W/sr, W/m^2), the scene's intensity_scale and environment radiance at most 1e12,
  reflectance colours at most 1e3;
- meshes and shapes at most 2^22 (4,194,304) triangles;
- line lights at most 1024 samples (GL techniques take 8 light samples in all).
"""
from __future__ import annotations

from contextlib import contextmanager
from numbers import Real

import numpy as np

from ..errors import SceneError, short

MAX_COORDINATE = 1e6
MIN_LENGTH = 1e-6
SCALE_RANGE = (1e-6, 1e6)
MAX_DEPTH_RATIO = 1e7
MAX_ROTATION = 1e6
IOR_RANGE = (0.1, 10.0)
MAX_INTENSITY = 1e12
MAX_COLOR = 1e3
MAX_TRIANGLES = 1 << 22
MAX_LINE_SAMPLES = 1024
MAX_IMAGE_SIZE = 16384


def _real(value) -> bool:
    """Whether ``value`` is one real number (numpy scalars and 0-d arrays included; bools and strings not)."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    return isinstance(value, (Real, np.number)) and not isinstance(value, (bool, np.bool_, complex, np.complexfloating))


def finite(value) -> bool:
    """Whether ``value`` is one real, finite number (a Python int too big for a float is not)."""
    try:
        return _real(value) and bool(np.isfinite(float(value)))
    except OverflowError:
        return False


def _range_text(low, high) -> str:
    return f"[{low:g}, {high:g}]"


def number(value, name: str, low: float = -np.inf, high: float = np.inf, hint: str = "",
           open_low: bool = False, open_high: bool = False, error=SceneError) -> float:
    """``value`` as a finite float in [low, high] (open at an end with ``open_low`` / ``open_high``)."""
    ok = finite(value)
    if ok:
        x = float(value)
        ok = (low < x if open_low else low <= x) and (x < high if open_high else x <= high)
    if not ok:
        bracket = ("(" if open_low else "[") + _range_text(low, high)[1:-1] + (")" if open_high else "]")
        what = f"a number in {bracket}" if np.isfinite(low) or np.isfinite(high) else "a finite number"
        raise error(f"{name} {short(value)} must be {what}{hint}")
    return x


def integer(value, name: str, low: int, high: int, hint: str = "", error=SceneError) -> int:
    """``value`` as an int in [low, high]; integral floats (2.0) pass, bools and strings do not."""
    whole = isinstance(value, (int, np.integer)) or (finite(value) and float(value) == int(value))
    if not (_real(value) and whole and low <= int(value) <= high):
        raise error(f"{name} {short(value)} must be an integer in [{low}, {high}]{hint}")
    return int(value)


def once_per_arrays(owner, names: tuple[str, ...], check) -> None:
    """Run ``check()`` unless the arrays ``owner.<name>`` are the very objects that passed it before.

    Renders validate the scene every frame; scalars are checked each time, but a large array (mesh
    vertices, an environment image) is read once per array object, as caustica's GPU and ray caches read
    it: edit such an array by assigning a new one, not in place."""
    current = tuple(getattr(owner, name) for name in names)
    passed = getattr(owner, "_arrays_passed", None)
    if passed is not None and all(a is b for a, b in zip(passed, current)):
        return
    check()
    owner._arrays_passed = tuple(getattr(owner, name) for name in names)


def flag(value, name: str, error=SceneError) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise error(f"{name} {short(value)} must be true or false")
    return bool(value)


def _array(value, name: str, count: int, what: str, error) -> np.ndarray:
    """``value`` as ``count`` finite float64 numbers, without numpy's conversion errors or overflow warnings."""
    if isinstance(value, np.ndarray) and value.dtype.kind == "f" and value.size == count:  # the usual case, fast
        array = value.astype(np.float64).reshape(-1)
        if np.isfinite(array).all():
            return array
    try:
        items = list(np.asarray(value, dtype=object).reshape(-1)) if not isinstance(value, (str, bytes)) else None
    except (TypeError, ValueError):
        items = None
    if items is None or len(items) != count or not all(finite(x) for x in items):
        raise error(f"{name} {short(value)} must be {what}")
    return np.array([float(x) for x in items], dtype=np.float64)


def vector(value, name: str, limit: float = MAX_COORDINATE, error=SceneError) -> np.ndarray:
    """Three finite numbers, each within +-``limit``."""
    v = _array(value, name, 3, "three finite numbers [x, y, z]", error)
    if np.max(np.abs(v)) > limit:
        raise error(f"{name} {short(v)} must lie within +-{limit:g} in each coordinate; bring the scene closer "
                    "to the origin or use smaller units")
    return v


def direction(value, name: str, error=SceneError) -> np.ndarray:
    """A non-zero vector, normalized."""
    v = vector(value, name, error=error)
    length = float(np.linalg.norm(v))
    if length < 1e-12:
        raise error(f"{name} {short(v)} must be a non-zero vector [x, y, z]")
    return v / length


def rgb(value, name: str, high: float, error=SceneError) -> np.ndarray:
    """One number (grey) or three [r, g, b], each finite in [0, ``high``]."""
    if finite(value) or (isinstance(value, np.ndarray) and value.size == 1):
        value = [np.asarray(value).reshape(-1)[0]] * 3
    arr = _array(value, name, 3, f"a number or three numbers [r, g, b] in [0, {high:g}]", error)
    if np.any(arr < 0) or np.any(arr > high):
        raise error(f"{name} {short(arr)} must be a number or three numbers [r, g, b] in [0, {high:g}]")
    return arr


def texture(value, name: str, error=SceneError) -> np.ndarray:
    """An (H, W, 3) image of finite values in [0, 1], at least 1x1 and at most MAX_IMAGE_SIZE a side, as
    contiguous float32."""
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        arr = np.zeros(0)
    if not np.issubdtype(arr.dtype, np.number) or np.issubdtype(arr.dtype, np.complexfloating) or arr.ndim != 3 \
            or arr.shape[2] != 3 or min(arr.shape[:2]) < 1 or max(arr.shape[:2]) > MAX_IMAGE_SIZE:
        raise error(f"{name} must be an RGB image (H, W, 3) of at most {MAX_IMAGE_SIZE} pixels a side "
                    f"(got shape {short(getattr(arr, 'shape', None))})")
    arr = np.ascontiguousarray(arr, dtype=np.float32)
    low, high = float(arr.min()), float(arr.max())
    if not (np.isfinite(low) and np.isfinite(high)) or low < 0.0 or high > 1.0:
        raise error(f"{name} must hold linear RGB values in [0, 1] (got {low:.3g} to {high:.3g}); "
                    "divide 8-bit images by 255 and decode sRGB first")
    return arr


def scale(value, name: str = "scale", error=SceneError) -> np.ndarray:
    """One number (uniform) or three, each in SCALE_RANGE."""
    low, high = SCALE_RANGE
    if finite(value) or (isinstance(value, np.ndarray) and value.size == 1):
        value = [np.asarray(value).reshape(-1)[0]] * 3
    arr = _array(value, name, 3, f"a number or three numbers in [{low:g}, {high:g}]", error)
    if np.any(arr < low) or np.any(arr > high):
        raise error(f"{name} {short(arr)} must be positive: a number or three numbers in [{low:g}, {high:g}]")
    return arr


def intensity_scale(value, error=SceneError) -> float:
    return number(value, "intensity_scale", 0.0, MAX_INTENSITY, open_low=True, error=error)


def ior(value, name: str = "ior", error=SceneError) -> float:
    return number(value, name, *IOR_RANGE, hint=" (glass is about 1.5, water 1.33, diamond 2.42; "
                  "below 1 for an air bubble)", error=error)


def triangles(count: int, what: str, fix: str, error=SceneError) -> None:
    """Refuse more than MAX_TRIANGLES triangles: ``what`` is e.g. "mesh 'x' has" or "resolution 9000 would make"."""
    if count > MAX_TRIANGLES:
        raise error(f"{what} {count:,} triangles, above the limit of {MAX_TRIANGLES:,}; {fix}")


def image_size(value, name: str = "camera.size", error=SceneError) -> tuple[int, int]:
    """(width, height): two integers in [1, MAX_IMAGE_SIZE]."""
    try:
        items = list(value) if not isinstance(value, (str, bytes, dict)) else None
    except TypeError:
        items = None
    if items is None or len(items) != 2 or not all(finite(v) and float(v) == int(v) for v in items):
        raise error(f"{name} must be two integers [width, height] (got {short(value)})")
    width, height = int(items[0]), int(items[1])
    if not (1 <= width <= MAX_IMAGE_SIZE and 1 <= height <= MAX_IMAGE_SIZE):
        raise error(f"{name} {short([width, height])} must lie between 1 and {MAX_IMAGE_SIZE} pixels a side")
    return width, height


def joined(where: str, message: str, keys=()) -> str:
    """``where.key ...`` when ``message`` starts with one of ``keys``, else ``where: message``."""
    first = message.split(" ", 1)[0]
    return f"{where}.{message}" if first in keys else f"{where}: {message}"


@contextmanager
def context(where: str, keys=()):
    """Re-raise a SceneError (or a ValueError of a scene dataclass) with ``where`` in front of its message."""
    try:
        yield
    except SceneError as exc:
        if str(exc).startswith(where):  # already names its key
            raise
        raise type(exc)(joined(where, str(exc), keys)) from None
    except ValueError as exc:
        raise SceneError(joined(where, str(exc), keys)) from None
