"""Compression of the light transport table (Iwasaki et al., section 6) and its file format.

Per sample, 12 bytes instead of 28:

- exit position: each component quantized to 16 bits within the object's
  bounding box, q = round((P_x - bx_min) / (bx_max - bx_min) * 65535);
- exit direction: azimuth theta in [0, 2 pi) and polar angle phi in [0, pi),
  16 bits each (2^32 directions);
- transmittance: 15 bits for F_t in [0, 1] plus the top bit for the
  self-occlusion flag (an invalid sample has F_t = 0).

The paper quantizes positions with a factor 2^16 (which overflows 16 bits at
the box's far side); 65535 keeps the far side representable. Files are ``.npz``
(numpy, no pickles) with a format version, the mesh hash, the IOR and the
direction count: :func:`load_table` refuses a file that does not match.
"""
from __future__ import annotations

import io
import zipfile
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import CausticaError
from .precompute import TABLE_VERSION, DirectionGrid, TransportTable

_Q16 = 65535.0
_T15 = 32767.0
_OCCLUDED_BIT = np.uint16(0x8000)


class TransportTableError(CausticaError, ValueError):
    """A light transport table file that is corrupt, of another version, or of another mesh/IOR."""


@dataclass
class QuantizedTable:
    """A transport table at 12 bytes a sample (section 6)."""

    position: np.ndarray  # (V, D, 3) uint16 within bounds
    direction: np.ndarray  # (V, D, 2) uint16: azimuth, polar angle
    transmittance: np.ndarray  # (V, D) uint16: 15 bits of F_t, top bit occluded
    ior: float
    grid: DirectionGrid
    max_depth: int
    mesh_hash: str
    bounds: np.ndarray  # (2, 3) float64

    @property
    def nbytes(self) -> int:
        return self.position.nbytes + self.direction.nbytes + self.transmittance.nbytes

    @property
    def bytes_per_sample(self) -> float:
        return self.nbytes / max(self.transmittance.size, 1)


def _extent(bounds: np.ndarray) -> np.ndarray:
    return np.maximum(bounds[1] - bounds[0], 1e-30)


BLOCK_SAMPLES = 1 << 18  # samples quantized or compared at a time: float64 temporaries of a few MB, not 100s


def _blocks(table) -> list[slice]:
    """Vertex ranges of about BLOCK_SAMPLES samples each."""
    vertices, directions = table.transmittance.shape
    step = max(1, BLOCK_SAMPLES // max(directions, 1))
    return [slice(lo, lo + step) for lo in range(0, vertices, step)]


def quantize(table: TransportTable) -> QuantizedTable:
    """Positions, directions and transmittance to 16 bits each component (section 6), block by block."""
    bounds = np.asarray(table.bounds, dtype=np.float64)
    shape = table.transmittance.shape
    position = np.empty((*shape, 3), np.uint16)
    direction = np.empty((*shape, 2), np.uint16)
    t = np.empty(shape, np.uint16)
    for part in _blocks(table):
        unit = (table.exit_position[part].astype(np.float64) - bounds[0]) / _extent(bounds)
        position[part] = np.round(np.clip(unit, 0.0, 1.0) * _Q16)
        d = table.exit_direction[part].astype(np.float64)
        theta = np.mod(np.arctan2(d[..., 1], d[..., 0]), 2.0 * np.pi)
        direction[part, ..., 0] = np.round(theta / (2.0 * np.pi) * 65536.0).astype(np.int64) % 65536
        direction[part, ..., 1] = np.round(np.arccos(np.clip(d[..., 2], -1.0, 1.0)) / np.pi * _Q16)
        t[part] = np.round(np.clip(table.transmittance[part].astype(np.float64), 0.0, 1.0) * _T15)
        t[part] |= np.where(table.occluded[part], _OCCLUDED_BIT, np.uint16(0))
    return QuantizedTable(position, direction, t, table.ior, table.grid, table.max_depth, table.mesh_hash, bounds)


def dequantize(q: QuantizedTable) -> TransportTable:
    """The float32 table the quantized one stands for."""
    bounds = q.bounds
    position = (q.position.astype(np.float64) / _Q16 * _extent(bounds) + bounds[0]).astype(np.float32)
    theta = q.direction[..., 0].astype(np.float64) * (2.0 * np.pi / 65536.0)
    phi = q.direction[..., 1].astype(np.float64) * (np.pi / _Q16)
    direction = np.stack([np.sin(phi) * np.cos(theta), np.sin(phi) * np.sin(theta), np.cos(phi)], -1).astype(np.float32)
    transmittance = ((q.transmittance & np.uint16(0x7FFF)).astype(np.float32) / np.float32(_T15))
    occluded = (q.transmittance & _OCCLUDED_BIT) != 0
    return TransportTable(position, direction, transmittance, occluded, transmittance > 0, q.ior, q.grid, q.max_depth,
                          q.mesh_hash, bounds)


def quantization_errors(table: TransportTable, q: QuantizedTable | None = None) -> dict:
    """Measured errors of the quantized table against the float one, and the sizes (section 7, fig. 12).

    position_error: max |P - P_q| per component over the bounding box extent (%);
    direction_error: max |d - d_q| (unit vectors: about the angle in radians) (%);
    transmittance_error: max |F_t - F_t,q|.
    """
    q = quantize(table) if q is None else q
    extent = _extent(table.bounds)
    position = direction = transmittance = 0.0
    for part in _blocks(table):  # block by block, as quantize: no table-sized float64 temporaries
        back = dequantize(replace(q, position=q.position[part], direction=q.direction[part],
                                  transmittance=q.transmittance[part]))
        position = max(position, float((np.abs(back.exit_position.astype(np.float64) - table.exit_position[part])
                                        / extent).max()))
        direction = max(direction, float(np.linalg.norm(back.exit_direction.astype(np.float64)
                                                        - table.exit_direction[part], axis=-1).max()))
        transmittance = max(transmittance, float(np.abs(back.transmittance - table.transmittance[part]).max()))
    return {
        "position_error_percent": position * 100.0,
        "direction_error_percent": direction * 100.0,
        "transmittance_error": transmittance,
        "raw_bytes": int(table.raw_bytes),
        "quantized_bytes": int(q.nbytes),
        "bytes_per_sample": float(q.bytes_per_sample),
        "size_ratio_percent": 100.0 * q.nbytes / max(table.raw_bytes, 1),
    }


def table_bytes(q: QuantizedTable) -> bytes:
    """The ``.npz`` file of a quantized table (no pickles), stored uncompressed: 16-bit samples hardly
    deflate (docs/cli.md, precompute)."""
    buffer = io.BytesIO()
    np.savez(buffer, version=np.int64(TABLE_VERSION), mesh_hash=np.str_(q.mesh_hash), ior=np.float64(q.ior),
                        rings=np.int64(q.grid.rings), max_depth=np.int64(q.max_depth), bounds=q.bounds,
                        position=q.position, direction=q.direction, transmittance=q.transmittance)
    return buffer.getvalue()


def save_table(path, q: QuantizedTable | bytes) -> None:
    """Write a quantized table (or its :func:`table_bytes`, made once for several files) atomically to ``path``."""
    from ..cache import atomic_write_bytes

    atomic_write_bytes(Path(path), q if isinstance(q, bytes) else table_bytes(q))


def load_table(path, mesh_hash: str | None = None, ior: float | None = None, directions: int | None = None) -> QuantizedTable:
    """Read a table file, refusing (TransportTableError) one that is corrupt or does not match."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            fields = {name: data[name] for name in data.files}
    except FileNotFoundError:
        raise TransportTableError(f"transport table '{path}' does not exist; run 'caustica precompute'") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise TransportTableError(f"transport table '{path}' is corrupt ({exc}); delete it and run "
                                  "'caustica precompute' again") from None
    missing = {"version", "mesh_hash", "ior", "rings", "max_depth", "bounds", "position", "direction",
               "transmittance"} - set(fields)
    if missing:
        raise TransportTableError(f"transport table '{path}' lacks {', '.join(sorted(missing))}; "
                                  "it is not a caustica table or is damaged: precompute it again")
    version = int(fields["version"])
    if version != TABLE_VERSION:
        raise TransportTableError(f"transport table '{path}' has format version {version}, this caustica reads "
                                  f"version {TABLE_VERSION}; precompute it again")
    grid = DirectionGrid(int(fields["rings"]))
    q = QuantizedTable(fields["position"], fields["direction"], fields["transmittance"], float(fields["ior"]), grid,
                       int(fields["max_depth"]), str(fields["mesh_hash"]), fields["bounds"].astype(np.float64))
    v = q.position.shape[0] if q.position.ndim == 3 else -1
    shapes_ok = (q.position.shape == (v, grid.count, 3) and q.direction.shape == (v, grid.count, 2)
                 and q.transmittance.shape == (v, grid.count)
                 and all(a.dtype == np.uint16 for a in (q.position, q.direction, q.transmittance))
                 and q.bounds.shape == (2, 3) and np.all(np.isfinite(q.bounds)))
    if not shapes_ok:
        raise TransportTableError(f"transport table '{path}' has inconsistent arrays; it is damaged: precompute it again")
    if mesh_hash is not None and q.mesh_hash != mesh_hash:
        raise TransportTableError(f"transport table '{path}' was computed for another mesh (hash {q.mesh_hash}, "
                                  f"this mesh is {mesh_hash}); precompute it for this mesh")
    if ior is not None and not np.isclose(q.ior, ior, rtol=0, atol=1e-9):
        raise TransportTableError(f"transport table '{path}' is for IOR {q.ior:g}, not {ior:g}; precompute it with --ior {ior:g}")
    if directions is not None and grid.count != directions:
        raise TransportTableError(f"transport table '{path}' has {grid.count} directions, not {directions}; "
                                  f"precompute it with --directions {directions}")
    return q
