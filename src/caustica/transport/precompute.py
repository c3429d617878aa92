"""The light transport table (Iwasaki et al., section 4): per vertex, where light leaves the object.

For every vertex P_i of a glass mesh and every sampled incident direction w_j
over the hemisphere about its normal, the light arriving along -w_j is
refracted at P_i (exact Fresnel transmittance, the vertex's shading normal)
and followed through the object with Embree, refracting at every interface
and reflecting internally where total internal reflection occurs, until it
leaves: exit position x_out, exit direction w_out and the product of the
Fresnel transmittances F_t, i.e. the light transport function
T(x_in, w_in) = (x_out, w_out, F_t) of equation (1).

Directions (section 4, fig. 3): a zenith sample plus ``rings`` elevation rings
(elevation k * 90 / rings degrees from the normal, k = 1..rings, the last on the
horizon) of ``2 rings`` azimuths each: ``2 rings^2 + 1`` samples, 129 for 8
rings as in the paper. The (elevation, azimuth) grid is what makes the run
time's "four nearest samples" a bilinear lookup (section 5.1). Azimuths are
measured in the vertex's tangent frame (:func:`tangent_frames`).

The refracted ray is followed through the whole object (the table is traced
against the object alone): a ray that leaves it and meets it again (an ear, then
the body) enters again, and one that leaves through a hole of an open mesh (a
scan's base) exits there, along its direction from its last surface point, with
the transmittances of the interfaces it met, as light does (and Embree's photons
and Mitsuba with it). The paper's objects are closed and says nothing of holes.

Flags: a sample is ``occluded`` when the object itself blocks the incident
ray before it reaches the vertex (concave objects), and not ``valid`` when the
refracted ray does not leave within ``max_depth`` interfaces (its transmittance
is then 0).

Everything is vectorised over vertices x directions; the rays go through
:class:`~caustica.raytrace.embree_scene.RayScene` in blocks, each block split
over every core (embreex releases the GIL), with progress on stderr (:mod:`caustica.progress`).
"""
from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError
from ..progress import progress as progress_display
from ..raytrace.embree_scene import RayScene
from ..raytrace.optics import fresnel_dielectric, normalize, refract
from ..raytrace.paths import follow_refraction
from ..scene.environment import procedural_environment
from ..scene.materials import Glass
from ..scene.mesh import Mesh
from ..scene.scene import Scene, SceneObject

# 2: a ray reflected totally and then leaking out of an open mesh was invalid; 3: light leaving through a
# hole of an open mesh exits there (version 2 dropped it);
# 4: the shading normal decides the side of each interface (raytrace/paths.interface), as in exact's images
TABLE_VERSION = 4
DEFAULT_DIRECTIONS = 129
DEFAULT_MAX_DEPTH = 8
BLOCK_RAYS = 1 << 19  # rays per block (bounded memory; each block uses every core)


@dataclass(frozen=True)
class DirectionGrid:
    """The sampled incident directions: the zenith, then ``rings`` rings of ``2 rings`` azimuths."""

    rings: int

    @property
    def azimuths(self) -> int:
        return 2 * self.rings

    @property
    def count(self) -> int:
        return self.rings * self.azimuths + 1

    @classmethod
    def of_count(cls, count: int) -> "DirectionGrid":
        """The grid of ``count`` = 2 r^2 + 1 directions (9, 33, 73, 129, 201, 289, 513, ...)."""
        rings = int(round(np.sqrt(max(int(count) - 1, 0) / 2.0)))
        if rings < 1 or 2 * rings * rings + 1 != int(count):
            near = sorted({2 * r * r + 1 for r in (max(rings - 1, 1), max(rings, 1), rings + 1)})
            raise ValueError(f"direction count {count} must be 2 r^2 + 1 (zenith + r rings of 2r azimuths), "
                             f"e.g. {', '.join(map(str, near))}")
        return cls(rings)

    def index(self, ring: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
        """Sample index of (ring 0..rings, azimuth 0..2 rings - 1); ring 0 is the zenith."""
        ring = np.asarray(ring)
        return np.where(ring == 0, 0, 1 + (ring - 1) * self.azimuths + np.mod(azimuth, self.azimuths))

    def local_directions(self) -> np.ndarray:
        """(count, 3) unit directions in the tangent frame (x tangent, y bitangent, z normal)."""
        ring, azimuth = np.meshgrid(np.arange(1, self.rings + 1), np.arange(self.azimuths), indexing="ij")
        elevation = ring.ravel() * (0.5 * np.pi / self.rings)
        theta = azimuth.ravel() * (2.0 * np.pi / self.azimuths)
        ring_dirs = np.stack([np.sin(elevation) * np.cos(theta), np.sin(elevation) * np.sin(theta), np.cos(elevation)], 1)
        return np.concatenate([[[0.0, 0.0, 1.0]], ring_dirs])


def tangent_frames(normals: np.ndarray) -> np.ndarray:
    """(V, 3, 3) orthonormal frames, rows (tangent, bitangent, normal): local = frame @ v."""
    n = normalize(np.asarray(normals, dtype=np.float64))
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t = normalize(np.cross(helper, n))
    b = np.cross(n, t)
    return np.stack([t, b, n], axis=1)


@dataclass
class TransportTable:
    """The light transport table of one mesh and IOR, in object space (float32, before quantization)."""

    exit_position: np.ndarray  # (V, D, 3) where the refracted light leaves the object (the vertex when invalid)
    exit_direction: np.ndarray  # (V, D, 3) unit direction it leaves along
    transmittance: np.ndarray  # (V, D) product of Fresnel transmittances (0 when invalid)
    occluded: np.ndarray  # (V, D) bool: the object blocks the incident direction
    valid: np.ndarray  # (V, D) bool: the light left the object within max_depth interfaces
    ior: float
    grid: DirectionGrid
    max_depth: int
    mesh_hash: str
    bounds: np.ndarray  # (2, 3) float64 box the positions are quantized in
    stats: dict = field(default_factory=dict)

    @property
    def vertex_count(self) -> int:
        return self.exit_position.shape[0]

    @property
    def sample_count(self) -> int:
        return self.exit_position.shape[0] * self.exit_position.shape[1]

    @property
    def raw_bytes(self) -> int:
        """Float32 position, direction and transmittance: 28 bytes a sample (the paper's uncompressed table)."""
        return self.sample_count * (12 + 12 + 4)


def glass_scene(mesh: Mesh, ior: float) -> Scene:
    """A scene of the mesh alone, as glass of index ``ior`` (what the table is traced against)."""
    # A black environment: the trace never looks it up, and the default sky costs 0.2 s to build.
    return Scene(objects=[SceneObject("transport", mesh, Glass(ior=ior))], environment=procedural_environment("black"))


def trace_samples(ray_scene: RayScene, scene: Scene, positions: np.ndarray, normals: np.ndarray,
                  incident: np.ndarray, ior: float, max_depth: int) -> dict:
    """The light transport function for rays arriving at surface points along -``incident``.

    ``positions``, ``normals`` (outward, unit) and ``incident`` (unit, towards the
    light) are (N, 3). The first refraction happens at the point itself with its
    normal; :func:`~caustica.raytrace.paths.follow_refraction` takes the ray
    from there to where it leaves. Returns exit_position, exit_direction,
    transmittance (0 where invalid), valid and occluded, (N, ...) float64 / bool.
    """
    incident = normalize(incident)
    cos_i = np.einsum("ij,ij->i", incident, normals)
    above = cos_i > 0.0
    # Refract into the glass at the point (exact Fresnel).
    inward, _ = refract(-incident, normals, np.full(len(incident), 1.0 / ior))
    first = 1.0 - fresnel_dielectric(cos_i, 1.0, ior)
    # Follow the refracted branch to the exit.
    paths = follow_refraction(ray_scene, scene, positions, inward, max_interfaces=max_depth, start_inside=True)
    # It leaves through glass, or through a hole of an open mesh.
    valid = above & (paths.valid | paths.leaked)
    transmittance = np.where(valid, first * paths.transmittance, 0.0)
    exit_position = np.where(valid[:, None], paths.position, positions)
    exit_direction = np.where(valid[:, None], paths.direction, -incident)
    # Self-occlusion: the object blocks the way from the vertex towards the light.
    occluded = ray_scene.occluded(positions, incident, np.inf) | ~above
    return {"exit_position": exit_position, "exit_direction": exit_direction, "transmittance": transmittance,
            "valid": valid, "occluded": occluded}


def precompute_table(mesh: Mesh, ior: float, directions: int = DEFAULT_DIRECTIONS, max_depth: int = DEFAULT_MAX_DEPTH,
                     analytic_spheres: bool = True, progress: bool = True, threads: int | None = None) -> TransportTable:
    """Trace every vertex x sampled direction of ``mesh`` (object space) as glass of index ``ior``.

    ``analytic_spheres`` traces a mesh that carries ``analytic_sphere`` as the
    true sphere (as the exact oracle does). ``progress`` shows progress on stderr
    (:mod:`caustica.progress`).
    """
    if not np.isfinite(ior) or ior <= 0:
        raise SceneError(f"ior {ior} must be positive (glass is about 1.5, water 1.33)")
    if int(max_depth) != max_depth or not 1 <= max_depth <= 64:
        raise ValueError(f"max_depth {max_depth} must be an integer in [1, 64]")
    grid = DirectionGrid.of_count(directions)
    start = time.perf_counter()
    scene = glass_scene(mesh, ior)
    ray_scene = RayScene(scene, analytic_spheres=analytic_spheres, threads=threads)
    vertices = mesh.vertices.astype(np.float64)
    frames = tangent_frames(mesh.normals)
    local = grid.local_directions()
    count, d = len(vertices), grid.count
    out = {
        "exit_position": np.empty((count, d, 3), np.float32), "exit_direction": np.empty((count, d, 3), np.float32),
        "transmittance": np.empty((count, d), np.float32), "valid": np.empty((count, d), bool),
        "occluded": np.empty((count, d), bool),
    }
    block = max(1, BLOCK_RAYS // d)
    bar = progress_display(count * d, f"transport table ({count} vertices x {d} directions)", unit="rays",
                           enabled=progress, unit_scale=True)

    def trace_block(lo: int) -> None:
        # Every direction of a block of vertices at once.
        hi = min(lo + block, count)
        world = np.einsum("vji,dj->vdi", frames[lo:hi], local).reshape(-1, 3)  # frame^T @ local
        positions = np.repeat(vertices[lo:hi], d, axis=0)
        normals = np.repeat(frames[lo:hi, 2], d, axis=0)
        result = trace_samples(ray_scene, scene, positions, normals, world, ior, max_depth)
        for name, values in result.items():
            out[name][lo:hi] = values.reshape(out[name][lo:hi].shape)
        bar.update((hi - lo) * d)

    # Blocks on every core: one block's numpy work overlaps another's Embree traversal.
    with ThreadPoolExecutor(ray_scene.threads) as pool:
        list(pool.map(trace_block, range(0, count, block)))
    bar.close()
    seconds = time.perf_counter() - start
    stats = {"seconds": seconds, "rays": int(ray_scene.rays_traced), "vertices": count, "directions": d,
             "valid_fraction": float(out["valid"].mean()), "occluded_fraction": float(out["occluded"].mean())}
    bounds = np.stack([vertices.min(axis=0), vertices.max(axis=0)])
    return TransportTable(ior=float(ior), grid=grid, max_depth=int(max_depth), mesh_hash=mesh.geometry_hash(),
                          bounds=bounds, stats=stats, **out)
