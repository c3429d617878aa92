"""Albedo textures of diffuse receivers: image files, procedural textures, and the lookup convention.

One convention, shared by the GPU (passes/shading/surfaces.py, common/surface_inputs.glsl) and the exact
oracle (raytrace/paths.py through :func:`sample_texture`): glTF's TEXCOORD_0, (u, v) = (0, 0) at the
image's top-left corner with v growing downwards, the image's row 0 its top row. Texel (column i,
row j) of a W x H image has its centre at ((i + 0.5) / W, (j + 0.5) / H), as in GL, which is given
the rows top first; lookups are bilinear and repeat in both directions (GL also mipmaps when
minifying). Pure data: no GL.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ..errors import SceneError, closest_name, first_line, short
from . import rules

TEXTURE_SUFFIXES = (".png", ".jpg", ".jpeg")
MAX_TEXTURE_PIXELS = 1 << 26  # 8192 x 8192: 768 MiB as float32 RGB


def checker(size: int = 64, squares: int = 8, dark: float = 0.15, light: float = 0.85) -> np.ndarray:
    """A ``squares`` x ``squares`` checkerboard, ``size`` texels a side, light in the top-left square."""
    cell = (np.arange(size) * squares) // size
    board = (cell[:, None] + cell[None, :]) % 2 == 0
    return np.repeat(np.where(board, light, dark)[..., None], 3, axis=2).astype(np.float32)


PROCEDURAL_TEXTURES = {"checker": checker}


def procedural_texture(name: str) -> np.ndarray:
    """A built-in texture by name (:data:`PROCEDURAL_TEXTURES`)."""
    if name not in PROCEDURAL_TEXTURES:
        raise SceneError(f"unknown procedural texture {short(name)}{closest_name(name, PROCEDURAL_TEXTURES)}; "
                         f"choose one of {', '.join(PROCEDURAL_TEXTURES)} or give a PNG/JPEG file")
    return PROCEDURAL_TEXTURES[name]()


def load_texture(path: str | Path, name: str = "texture", srgb: bool = True) -> np.ndarray:
    """A PNG or JPEG file as a texture: sRGB decoded to linear RGB in [0, 1], (H, W, 3) float32 (``srgb``
    False: its codes scaled to [0, 1], for data textures: metallic-roughness, normal and occlusion maps).

    SceneError (one line, naming ``name`` and the file) when the file is missing, not PNG/JPEG,
    unreadable, or larger than MAX_TEXTURE_PIXELS or rules.MAX_IMAGE_SIZE a side (read from its
    header, before decoding)."""
    path = Path(path)
    if path.suffix.lower() not in TEXTURE_SUFFIXES:
        raise SceneError(f"{name} {path} is not a PNG or JPEG file; give one of {', '.join(TEXTURE_SUFFIXES)}")
    if not path.is_file():
        raise SceneError(f"{name} file not found: {path}; check the path (relative to the scene file)")
    return _decoded(path, f"{name} {path}", name, srgb)


def decode_texture(data: bytes, label: str, name: str = "texture", srgb: bool = True) -> np.ndarray:
    """PNG or JPEG bytes (e.g. an image embedded in a glTF file) as :func:`load_texture` gives them;
    ``label`` names the image in errors."""
    return _decoded(io.BytesIO(bytes(data)), label, name, srgb)


def _decoded(source, label: str, name: str, srgb: bool = True) -> np.ndarray:
    """The image at ``source`` (a path or a binary file), its size checked from the header first."""
    from PIL import Image

    from ..images import decode_8bit

    too_large = (f"{label} is larger than the {rules.MAX_IMAGE_SIZE} pixels a side and {MAX_TEXTURE_PIXELS:,} "
                 "pixels caustica takes for a texture; downscale it")
    try:
        with Image.open(source) as img:
            width, height = img.size
            kind = img.format
    except Image.DecompressionBombError:  # Pillow's own limit, checked from the header too
        raise SceneError(too_large) from None
    except Exception as exc:  # Pillow raises many types for a file it cannot identify
        raise SceneError(f"cannot read {label}: {first_line(exc)}; give a valid PNG or JPEG image") from None
    if kind not in ("PNG", "JPEG"):
        raise SceneError(f"{label} is a {kind} image; give a PNG or JPEG image")
    if max(width, height) > rules.MAX_IMAGE_SIZE or width * height > MAX_TEXTURE_PIXELS:
        raise SceneError(too_large.replace(" is larger", f" is {width}x{height} pixels, larger"))
    if hasattr(source, "seek"):
        source.seek(0)
    try:
        image = decode_8bit(source, srgb)
    except Exception as exc:  # a truncated file fails only when decoded
        raise SceneError(f"cannot read {label}: {first_line(exc)}; give a valid PNG or JPEG image") from None
    return rules.texture(np.clip(image, 0.0, 1.0), name)


def texture_of(obj, material=None) -> np.ndarray | None:
    """The albedo texture ``obj`` shows when drawn with ``material`` (default its own): a diffuse
    material's texture where the mesh has uvs, else None."""
    material = obj.material if material is None else material
    texture = getattr(material, "texture", None) if material.kind == "diffuse" else None
    return texture if texture is not None and obj.mesh.uvs is not None else None


def sample_texture(texture: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear, repeating lookups of ``texture`` (H, W, 3) at ``uv`` (N, 2) in the module's convention:
    (N, 3) float64."""
    height, width = texture.shape[:2]
    uv = np.asarray(uv, np.float64).reshape(-1, 2)
    x, y = uv[:, 0] * width - 0.5, uv[:, 1] * height - 0.5  # texel centres at integers
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    i0, j0 = x0.astype(np.int64) % width, y0.astype(np.int64) % height
    i1, j1 = (i0 + 1) % width, (j0 + 1) % height
    def texels(j, i):  # gathered first, then widened: the image itself is not copied
        return texture[j, i].astype(np.float64)

    top = texels(j0, i0) * (1.0 - fx) + texels(j0, i1) * fx
    bottom = texels(j1, i0) * (1.0 - fx) + texels(j1, i1) * fx
    return top * (1.0 - fy) + bottom * fy
