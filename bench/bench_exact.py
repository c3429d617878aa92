"""Throughput of the exact oracle: rays per second of ``RayScene.intersect`` and of ``trace``.

Usage: ``.venv/bin/python bench/bench_exact.py [--rays N]``. Uses the Stanford
bunny from ../shared/data when present, and a procedural sphere (mesh and
analytic). Timings are wall clock on the CPU; the machine is printed with them.
"""
from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

from caustica.raytrace.embree_scene import RayScene
from caustica.raytrace.paths import trace
from caustica.scene import Camera, Glass, Scene, SceneObject
from caustica.scene.mesh import Mesh
from caustica.scene.mesh_files import load_mesh
from caustica.scene.shapes import sphere

BUNNY = Path(__file__).resolve().parents[2] / "shared" / "data" / "models" / "stanford-bunny.obj"


def rays_at(mesh: Mesh, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Rays from a sphere around the mesh towards points near its centre (most hit)."""
    rng = np.random.default_rng(seed)
    lo, hi = mesh.bounds.astype(np.float64)
    center, radius = (lo + hi) / 2, np.linalg.norm(hi - lo)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    targets = center + (rng.uniform(-0.5, 0.5, (n, 3)) * (hi - lo))
    origins = targets - d * radius
    return origins, d


def timed(fn, repeat: int = 3) -> float:
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def bench_mesh(name: str, mesh: Mesh, n_rays: int, analytic: bool) -> None:
    scene = Scene(objects=[SceneObject(name, mesh, Glass(1.5))])
    start = time.perf_counter()
    rs = RayScene(scene, analytic_spheres=analytic)
    build = time.perf_counter() - start
    origins, dirs = rays_at(mesh, n_rays)
    hit_fraction = rs.intersect(origins[:1000], dirs[:1000]).hit.mean()
    t_intersect = timed(lambda: rs.intersect(origins, dirs))
    # A 512x512 camera image through the glass object.
    lo, hi = mesh.bounds.astype(np.float64)
    center, size = (lo + hi) / 2, np.linalg.norm(hi - lo)
    camera = Camera(position=center + [0.0, 0.2 * size, 1.6 * size], look_at=center, size=(512, 512))
    cam_o, cam_d = camera.primary_rays(1)
    cam_o, cam_d = cam_o.reshape(-1, 3), cam_d.reshape(-1, 3)
    t_trace = timed(lambda: trace(rs, scene, cam_o, cam_d), repeat=1)
    kind = "analytic" if analytic and rs.spheres else f"{len(mesh.faces)} triangles"
    print(
        f"{name:8s} ({kind}): build {build * 1e3:7.1f} ms | intersect {n_rays / t_intersect / 1e6:6.2f} M rays/s "
        f"(hits {hit_fraction:.0%}) | trace 512x512 glass {len(cam_o) / t_trace / 1e6:6.2f} M primary rays/s "
        f"({t_trace:.2f} s)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rays", type=int, default=2_000_000, help="rays per intersect batch")
    args = parser.parse_args()
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPU cores, numpy {np.__version__}")
    if BUNNY.exists():
        bench_mesh("bunny", load_mesh(BUNNY), args.rays, analytic=False)
    else:
        print(f"bunny skipped: {BUNNY} not found")
    ball = sphere(1.0, 6)
    bench_mesh("sphere", ball, args.rays, analytic=False)
    ball.analytic_sphere = (np.zeros(3), 1.0)
    bench_mesh("sphere", ball, args.rays, analytic=True)


if __name__ == "__main__":
    main()
