"""Sample planes (Iwasaki et al. 5.2): caustics maps, illumination maps and sliced object images.

The illumination volumes of the run time (``caustica.transport.runtime``:
per lit triangle of a glass object, the three refracted vertex rays carrying
the flux E S F_t, eq. 2) are cut by virtual planes around the object:

- **caustics map** of a plane: each volume meets the plane in a triangle
  S_p (its three rays intersected with the plane, analytically); the volume's
  flux spreads uniformly over S_p (intensity E S F_t / S_p, eq. 2) and the
  triangles accumulate into a texel grid, in W/m^2 (:func:`caustics_map`). The
  triangles are drawn as the centroids of an m x m subdivision, m set so that a
  sub-triangle is about half a texel; a volume crosses the plane only when all
  three rays reach it ahead of their exit points.
- **illumination map** of a plane (the slab between it and the next plane):
  the diffuse surfaces in the slab projected onto the plane along its normal,
  reflectance in RGB and coverage in alpha (:func:`illumination_map`).
- **sliced object image**: caustics map times illumination map: the caustic
  irradiance times the reflectance of the surface in the slab
  (:func:`sliced_object_images`).

A plane is ``(origin, u, v, extent, resolution)``, as
:func:`caustica.raytrace.photons.irradiance_histogram` takes it: the rectangle
centred on ``origin`` along the unit axes u and v, ``extent`` one size or
(width along u, height along v), ``resolution`` one count or (cols, rows);
``out[j, i]`` is the texel at column i along u, row j along v (row 0 at -v).
The slab of an illumination map is the side of the plane along u x v.

Limits: sample planes are virtual, so nothing occludes the volumes on their way
(as in the paper); volumes whose rays miss a plane (pointing away, or exiting
past it) are left out of it.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..raytrace.optics import normalize
from .runtime import ExitRays, object_exit_rays, receiver_scene, subdivision_barycentrics

MAX_SUBDIVISION = 32  # a volume's slice is drawn with at most 32^2 sub-triangles


@dataclass
class SamplePlane:
    origin: np.ndarray  # (3,) centre
    u: np.ndarray  # (3,) unit axis of the columns
    v: np.ndarray  # (3,) unit axis of the rows
    width: float
    height: float
    cols: int
    rows: int

    @classmethod
    def of(cls, spec) -> "SamplePlane":
        """A plane from ``(origin, u, v, extent, resolution)`` (or a SamplePlane)."""
        if isinstance(spec, SamplePlane):
            return spec
        origin, u, v, extent, resolution = spec
        u, v = normalize(np.asarray(u, np.float64)), normalize(np.asarray(v, np.float64))
        if abs(float(u @ v)) > 1e-6:
            raise ValueError("a sample plane's u and v axes must be perpendicular")
        width, height = np.broadcast_to(np.asarray(extent, np.float64), (2,))
        cols, rows = np.broadcast_to(np.asarray(resolution, np.int64), (2,))
        if width <= 0 or height <= 0 or cols < 1 or rows < 1:
            raise ValueError("a sample plane needs a positive extent and resolution")
        return cls(np.asarray(origin, np.float64), u, v, float(width), float(height), int(cols), int(rows))

    @property
    def normal(self) -> np.ndarray:
        return np.cross(self.u, self.v)

    @property
    def texel_area(self) -> float:
        return self.width / self.cols * self.height / self.rows

    def accumulate(self, points: np.ndarray, flux: np.ndarray) -> np.ndarray:
        """Flux (N, 3) at points (N, 3) on the plane binned into (rows, cols, 3) W/m^2."""
        rel = points - self.origin
        i = np.floor((rel @ self.u / self.width + 0.5) * self.cols).astype(np.int64)
        j = np.floor((rel @ self.v / self.height + 0.5) * self.rows).astype(np.int64)
        keep = (i >= 0) & (i < self.cols) & (j >= 0) & (j < self.rows)
        flat = j[keep] * self.cols + i[keep]
        size = self.rows * self.cols
        out = np.stack([np.bincount(flat, weights=flux[keep, c], minlength=size) for c in range(3)], axis=-1)
        return out.reshape(self.rows, self.cols, 3) / self.texel_area


def volume_slices(rays: ExitRays, plane: SamplePlane) -> tuple[np.ndarray, np.ndarray]:
    """The illumination volumes' intersections with ``plane``: triangles (K, 3, 3) and their flux (K, 3)."""
    faces, flux = rays.faces, rays.volume_flux
    n = plane.normal
    along = rays.direction @ n
    t = ((plane.origin - rays.origin) @ n) / np.where(np.abs(along) > 1e-12, along, np.nan)
    reaches = np.isfinite(t) & (t >= 0.0)
    keep = (flux.max(axis=1) > 0) & reaches[faces].all(axis=1)
    points = rays.origin + np.nan_to_num(t)[:, None] * rays.direction
    return points[faces[keep]], flux[keep]


def caustics_map(rays: ExitRays, plane: SamplePlane) -> np.ndarray:
    """Caustic irradiance (rows, cols, 3) W/m^2 on ``plane`` from one object's illumination volumes."""
    triangles, flux = volume_slices(rays, plane)
    area = 0.5 * np.linalg.norm(np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]), axis=1)
    sub = np.clip(np.ceil(2.0 * np.sqrt(area / plane.texel_area)), 1, MAX_SUBDIVISION).astype(np.int64)
    out = np.zeros((plane.rows, plane.cols, 3))
    for m in np.unique(sub):
        pick = sub == m
        bary = subdivision_barycentrics(int(m))
        points = np.einsum("kc,fcx->fkx", bary, triangles[pick]).reshape(-1, 3)
        out += plane.accumulate(points, np.repeat(flux[pick] / (m * m), len(bary), axis=0))
    return out


def illumination_map(scene, plane, thickness: float) -> np.ndarray:
    """Diffuse surfaces within [0, ``thickness``) of ``plane`` along u x v, projected onto it: (rows, cols, 4),
    reflectance in RGB, coverage (0 or 1) in alpha; one ray per texel centre."""
    plane = SamplePlane.of(plane)
    receivers = scene.objects_of("diffuse")
    out = np.zeros((plane.rows, plane.cols, 4))
    if not receivers:
        return out
    a = ((np.arange(plane.cols) + 0.5) / plane.cols - 0.5) * plane.width
    b = ((np.arange(plane.rows) + 0.5) / plane.rows - 0.5) * plane.height
    bb, aa = np.meshgrid(b, a, indexing="ij")
    centres = plane.origin + aa.reshape(-1, 1) * plane.u + bb.reshape(-1, 1) * plane.v
    back = 1e-4 * thickness  # start just behind the plane, so surfaces lying on it count
    n = np.broadcast_to(plane.normal, centres.shape)
    hits = receiver_scene(receivers).intersect(centres - back * n, n, tnear=0.0)
    inside = hits.hit & (hits.t < thickness)  # [0, thickness): a surface on the next plane is in its slab
    colors = np.array([np.asarray(getattr(o.material, "color", np.ones(3)), np.float64) for o in receivers])
    out[..., :3] = np.where(inside[:, None], colors[np.maximum(hits.object_index, 0)], 0.0).reshape(plane.rows, plane.cols, 3)
    out[..., 3] = inside.reshape(plane.rows, plane.cols)
    return out


def _light_samples(scene, light_index: int):
    from ..lighting.samples import light_samples

    if not 0 <= light_index < len(scene.lights):
        raise ValueError(f"light_index {light_index} is not one of the scene's {len(scene.lights)} lights")
    return light_samples(replace(scene, lights=[scene.lights[light_index]]))


def sample_plane_maps(scene, light_index: int, planes, directions: int = 129, max_depth: int = 8,
                      quantized: bool = True) -> list[np.ndarray]:
    """Caustics maps (rows, cols, 3) W/m^2 of every glass object of ``scene`` under light ``light_index``
    (all its samples: a line light's points) on each plane ``(origin, u, v, extent, resolution)``."""
    planes = [SamplePlane.of(p) for p in planes]
    maps = [np.zeros((p.rows, p.cols, 3)) for p in planes]
    for sample in _light_samples(scene, light_index):
        for obj in scene.objects_of("glass"):
            for rays in object_exit_rays(obj, sample, directions, max_depth, quantized, progress=False):
                for out, plane in zip(maps, planes):
                    out += caustics_map(rays, plane)
    return maps


def sliced_object_images(scene, light_index: int, planes, **table) -> list[np.ndarray]:
    """Sliced object images (rows, cols, 4): caustic irradiance times the reflectance of the diffuse surface
    in each plane's slab (up to the next plane; the last plane's slab as thick as the one before it, or 1e-3
    of its extent alone) in RGB, the coverage in alpha (the masking of 5.3)."""
    planes = [SamplePlane.of(p) for p in planes]
    caustics = sample_plane_maps(scene, light_index, planes, **table)
    gaps = [float(abs((b.origin - a.origin) @ a.normal)) for a, b in zip(planes, planes[1:])]
    gaps.append(gaps[-1] if gaps else 1e-3 * max(planes[0].width, planes[0].height))
    out = []
    for plane, caustic, gap in zip(planes, caustics, gaps):
        illumination = illumination_map(scene, plane, gap)
        out.append(np.concatenate([caustic * illumination[..., :3], illumination[..., 3:]], axis=-1))
    return out
