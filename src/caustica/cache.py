"""On-disk caches (Mitsuba references, d_N per mesh, ...): one folder per kind, atomic writes.

The root is ``$CAUSTICA_CACHE`` or ``~/.cache/caustica``. A missing or damaged
entry is recomputed; a cache that cannot be written only costs a recompute.
"""
from __future__ import annotations

import hashlib
import os
import re
import weakref
from collections import OrderedDict
from pathlib import Path

import numpy as np

from .atomic import write_atomic
from .errors import OutputError


def cache_dir(kind: str) -> Path:
    """The folder of one kind of cached data (not created here)."""
    env = os.environ.get("CAUSTICA_CACHE")
    return (Path(env) if env else Path.home() / ".cache" / "caustica") / kind


def slug(text: str, limit: int = 40) -> str:
    """A readable file-name prefix from user text (a scene name): only [A-Za-z0-9_-], at most ``limit``
    characters, never empty; no separator, '..' or NUL can pass. Cache keys stay hashes; this is a label."""
    return re.sub(r"[^A-Za-z0-9_-]+", "-", str(text)).strip("-")[:limit] or "unnamed"


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` atomically to ``path`` (its folder created), through :func:`caustica.atomic.write_atomic`:
    OutputError (an OSError) when it cannot be written, nothing left on disk."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create the folder {path.parent} ({exc.strerror}); check permissions") from None
    write_atomic(path, lambda tmp: Path(tmp).write_bytes(data))


def load_array(path: Path, shape: tuple | None = None, dtype=None) -> np.ndarray | None:
    """A cached array, or None when missing, unreadable, non-finite or not of the expected shape/dtype."""
    try:
        values = np.load(path, allow_pickle=False)
    except (OSError, ValueError):
        return None
    if shape is not None and values.shape != tuple(shape):
        return None
    if dtype is not None and values.dtype != np.dtype(dtype):
        return None
    if values.dtype.kind == "f" and not np.all(np.isfinite(values)):
        return None
    return values


def store_array(path: Path, values: np.ndarray) -> bool:
    """Save atomically; False (and nothing on disk) when the cache cannot be written."""
    import io

    buffer = io.BytesIO()
    np.save(buffer, np.asarray(values), allow_pickle=False)
    try:
        atomic_write_bytes(path, buffer.getvalue())
    except OSError:
        return False
    return True


def kept_on(owner, attribute: str, key, compute):
    """``compute()``'s value, kept on ``owner`` (a scene, an environment) as ``attribute`` with ``key`` and
    given back while the key stays equal: one value per owner and attribute, recomputed when the key moves."""
    kept = getattr(owner, attribute, None)
    if kept is None or kept[0] != key:
        kept = (key, compute())
        setattr(owner, attribute, kept)
    return kept[1]


DIGEST_BYTES = 4096  # arrays larger than this (a texture) are keyed by array_digest, not by their bytes


def state_key(value):
    """A hashable stand-in for a dataclass of numbers and arrays (a light, a material), for keys of
    per-frame caches: equal exactly when the values are. Cheaper than ``repr``, which
    formats every array. An array above DIGEST_BYTES (a material's texture) is keyed by
    :func:`array_digest`, hashed once while it lives."""
    if isinstance(value, np.ndarray):
        if value.nbytes > DIGEST_BYTES:
            return (value.dtype.str, value.shape, array_digest(value))
        return (value.dtype.str, value.shape, value.tobytes())
    if hasattr(value, "__dataclass_fields__"):
        return (type(value).__name__, *(state_key(getattr(value, name)) for name in value.__dataclass_fields__))
    if isinstance(value, (list, tuple)):
        return tuple(state_key(v) for v in value)
    try:
        hash(value)
    except TypeError:
        return repr(value)
    return value


class LruCache(OrderedDict):
    """A dict that keeps its ``max_entries`` most recently used entries; ``on_evict(value)``, when
    given, frees the others."""

    def __init__(self, max_entries: int, on_evict=None):
        super().__init__()
        self.max_entries, self.on_evict = int(max_entries), on_evict

    def __getitem__(self, key):
        value = super().__getitem__(key)
        self.move_to_end(key)
        return value

    def get(self, key, default=None):
        return self[key] if key in self else default

    def __setitem__(self, key, value) -> None:
        super().__setitem__(key, value)
        self.move_to_end(key)
        while len(self) > self.max_entries:
            evicted = self.popitem(last=False)[1]
            if self.on_evict is not None:
                self.on_evict(evicted)

    def pop_release(self, key) -> None:
        """Remove ``key`` and free its value with ``on_evict`` (a no-op for a missing key)."""
        if key in self:
            value = super().pop(key)
            if self.on_evict is not None:
                self.on_evict(value)


_DIGESTS: dict[int, tuple] = {}  # id(array) -> (weak reference to it, digest); an entry goes with its array


def scene_state_key(scene) -> tuple:
    """What shadow maps and light paths depend on: lights, the environment (its sun is a light:
    passes/shading/environment.py) and object geometry and placement."""
    parts = [state_key(light) for light in scene.lights]
    parts.append(("environment", array_digest(scene.environment.image)))
    for obj in scene.objects:
        parts.append((obj.mesh.content_hash(), tuple(np.round(obj.world_from_object().ravel(), 9))))
    return tuple(parts)


def material_state_key(scene) -> tuple:
    """What caustics depend on beyond :func:`scene_state_key`: every object's material."""
    return tuple(state_key(o.material) for o in scene.objects)


def array_digest(array: np.ndarray) -> str:
    """A hash of ``array``'s shape, type and bytes, computed once while the array lives (an
    environment image or a texture is hashed when first seen, not each frame; change an image by
    assigning a new array, not in place)."""
    key = id(array)
    entry = _DIGESTS.get(key)
    if entry is not None and entry[0]() is array:
        return entry[1]
    data = np.ascontiguousarray(array)
    h = hashlib.blake2b(f"{data.dtype.str}{data.shape}".encode(), digest_size=16)
    h.update(memoryview(data).cast("B"))
    digest = h.hexdigest()
    _DIGESTS[key] = (weakref.ref(array, lambda _, k=key: _DIGESTS.pop(k, None)), digest)
    return digest
