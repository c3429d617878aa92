"""The contract between caustic techniques and the surface-shading pass.

A caustic technique's passes write the channel ``caustic_maps``: one
:class:`CausticMap` per light sample (in the order of ``light_samples``), or
None for a light that makes no caustic. A texel holds the irradiance (W/m^2,
RGB) that light focused by refractors or reflectors delivers to the receiver
surface the texel sees from the light, and in alpha that surface's distance to
the light (dot with the direction for directional lights; 0 where empty).
``ShadeSurfaces`` adds it to the diffuse irradiance when the channel exists
(``shaders/common/caustics.glsl``).

Or it writes ``caustic_tiles`` (:class:`CausticTiles`, Hu and Qin 3.3): caustic
textures on rectangles between casters and receivers, which each receiver
fragment looks up by the rectangles' parallel projections as it is shaded.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...render.draw import clip_corners
from ..shading.shadows import LIGHT_DIRECTIONAL

CAUSTIC_NONE, CAUSTIC_PROJECTIVE, CAUSTIC_CUBE = 0, 1, 2


@dataclass
class CausticMap:
    """One light's caustic map: an rgba32f texture and how receivers find their texel."""

    texture: object
    kind: int  # CAUSTIC_PROJECTIVE (clip_from_world) or CAUSTIC_CUBE (six-face atlas, 6N x N)
    clip_from_world: np.ndarray | None = None
    lit: np.ndarray | None = field(default=None, repr=False, compare=False)  # lit_boxes, read back once


LIT_BLOCK = 16  # texels a side of the blocks whose lit receiver points lit_boxes bounds together
LIT_MARGIN = 2  # texels the lit area is grown by first: a splat's light reaches past its photon's texel


def _block_bounds(values: np.ndarray, block: int, reduce) -> np.ndarray:
    """(rows, cols) ``reduce`` (np.min or np.max) of each block x block tile of the (H, W) ``values``, whose
    sides are whole blocks."""
    h, w = values.shape
    return reduce(reduce(values.reshape(h // block, block, w // block, block), axis=3), axis=1)


def lit_boxes(caustic: CausticMap, sample) -> np.ndarray:
    """(k, 2, 3) world boxes (min, max) that hold the receiver points of every lit texel of a projective caustic
    map, the lit area grown by LIT_MARGIN texels, a box per LIT_BLOCK x LIT_BLOCK block: each texel's point lies
    along its ray at the distance its alpha holds (caustics.glsl's d: along the direction for a directional light,
    from the light otherwise). Read back once per map and kept on it."""
    if caustic.lit is not None:
        return caustic.lit
    from scipy import ndimage  # only where reflection maps ask (scipy.ndimage costs start-up otherwise)

    texture = caustic.texture
    texels = np.frombuffer(texture.read(), np.float32).reshape(texture.height, texture.width, 4)
    lit = (texels[..., 0] > 0.0) | (texels[..., 1] > 0.0) | (texels[..., 2] > 0.0)
    lit = ndimage.binary_dilation(lit, structure=np.ones((3, 3), bool), iterations=LIT_MARGIN)
    rows, cols = np.nonzero(lit & (texels[..., 3] > 0.0))  # lit, with a receiver there
    if not len(rows):
        caustic.lit = np.zeros((0, 2, 3))
        return caustic.lit
    # Each texel's ray from the map's near plane to its far plane, and its point at the alpha's distance.
    ndc = np.stack([(cols + 0.5) / texture.width * 2.0 - 1.0, (rows + 0.5) / texture.height * 2.0 - 1.0], axis=1)
    world_from_clip = np.linalg.inv(np.asarray(caustic.clip_from_world, np.float64))
    near, far = ((np.c_[ndc, np.full(len(ndc), z), np.ones(len(ndc))] @ world_from_clip.T) for z in (-1.0, 1.0))
    near, far = near[:, :3] / near[:, 3:4], far[:, :3] / far[:, 3:4]
    origin, direction = np.asarray(sample.position, np.float64), np.asarray(sample.direction, np.float64)
    if sample.type == LIGHT_DIRECTIONAL:
        d_near, d_far = (near - origin) @ direction, (far - origin) @ direction
    else:
        d_near, d_far = np.linalg.norm(near - origin, axis=1), np.linalg.norm(far - origin, axis=1)
    span = np.where(np.abs(d_far - d_near) > 1e-12, d_far - d_near, 1e-12)
    points = near + ((texels[rows, cols, 3] - d_near) / span)[:, None] * (far - near)
    # The bounds of each block's points, an axis at a time (empty texels: +inf / -inf).
    h, w = -(-texture.height // LIT_BLOCK) * LIT_BLOCK, -(-texture.width // LIT_BLOCK) * LIT_BLOCK
    flat, bounds = rows * w + cols, []
    for reduce, empty in ((np.min, np.inf), (np.max, -np.inf)):
        axes = []
        for axis in range(3):
            values = np.full(h * w, empty)
            values[flat] = points[:, axis]
            axes.append(_block_bounds(values.reshape(h, w), LIT_BLOCK, reduce))
        bounds.append(np.stack(axes, axis=-1))
    filled = np.isfinite(bounds[0][..., 0])
    caustic.lit = np.stack([bounds[0][filled], bounds[1][filled]], axis=1)
    return caustic.lit


def maps_reaching(maps: list | None, samples: list, clip_from_world: np.ndarray) -> bool:
    """Whether any light's caustic map (``caustic_maps``, in the order of ``samples``) can put light inside the
    view volume of ``clip_from_world``: a projective map where a box of its lit receiver points (lit_boxes) is
    not wholly outside one face of the volume; a cube map anywhere."""
    for caustic, sample in zip(maps or (), samples):
        if caustic is None:
            continue
        if caustic.kind != CAUSTIC_PROJECTIVE or caustic.clip_from_world is None:
            return True
        boxes = lit_boxes(caustic, sample)
        if not len(boxes):
            continue
        clip = clip_corners(boxes, clip_from_world)  # (k, 8, 4)
        w = clip[..., 3]
        outside = np.zeros(len(boxes), bool)
        for axis in range(3):  # each face is a plane in world space: x > w, x < -w, ...
            outside |= np.all(clip[..., axis] > w, axis=1) | np.all(clip[..., axis] < -w, axis=1)
        if not outside.all():
            return True
    return False




@dataclass
class CausticTiles:
    """Caustic textures on rectangles (Hu and Qin 3.2-3.3): irradiance across each rectangle's axis,
    side by side in one rgba32f atlas; ``receivers[k]`` is the object tile k's rectangle stands for."""

    texture: object
    tile_size: int
    clip_from_world: np.ndarray  # (N, 4, 4): each rectangle's parallel projection
    axes: np.ndarray  # (N, 3): unit projection axes, from the caster towards the receiver
    receivers: list
    texel_areas: np.ndarray  # (N,): area one texel covers on each rectangle (scene units squared)

    def tiles_of(self, obj) -> list[int]:
        """The tiles lying on ``obj``."""
        return [k for k, receiver in enumerate(self.receivers) if receiver is obj]


