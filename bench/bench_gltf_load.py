"""Load time of a 1M-triangle glTF: ``caustica.load_scene`` on a generated heightfield ``.glb``.

Usage: ``.venv/bin/python bench/bench_gltf_load.py [--cells 708] [--repeat 3] [--no-normals]``.
The heightfield (``cells`` x ``cells`` quads, two triangles each: 1,002,528 at 708) is written by
caustica's own glTF writer into a temporary folder, with POSITION, NORMAL and TEXCOORD_0; the
best of ``repeat`` loads is printed with a breakdown (file and JSON, accessors, meshes, bounds, the
default environment).
``--no-normals`` drops NORMAL so that the loader computes them.
"""
from __future__ import annotations

import argparse
import cProfile
import json
import os
import platform
import pstats
import tempfile
import time
from pathlib import Path

import numpy as np

import caustica
from caustica.scene import Camera, Diffuse, Mesh, Scene, SceneObject
from caustica.scene.gltf import write_gltf


def heightfield(cells: int) -> Mesh:
    """A wavy (cells x cells)-quad grid over [-1, 1]^2 with analytic normals and uvs."""
    n = cells + 1
    x, z = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n), indexing="ij")
    y = 0.05 * np.sin(8 * x) * np.cos(6 * z)
    normals = np.stack([-0.4 * np.cos(8 * x) * np.cos(6 * z), np.ones_like(y), 0.3 * np.sin(8 * x) * np.sin(6 * z)], -1)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    index = np.arange(n * n).reshape(n, n)
    a, b, c, d = index[:-1, :-1], index[:-1, 1:], index[1:, :-1], index[1:, 1:]
    faces = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)])
    uvs = np.stack([(x + 1) / 2, (z + 1) / 2], -1).reshape(-1, 2)
    return Mesh(np.stack([x, y, z], -1).reshape(-1, 3), normals.reshape(-1, 3), faces, name="terrain", uvs=uvs)


def timed_loads(path: Path, repeat: int) -> list[float]:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        caustica.load_scene(path)
        times.append(time.perf_counter() - start)
    return times


def breakdown(path: Path) -> dict[str, float]:
    """Seconds (cumulative, one profiled load) in the file layer, accessor decoding, Mesh construction, the
    scene bounds (the framing and far plane need them) and the default sky-checker environment."""
    profile = cProfile.Profile()
    profile.enable()
    caustica.load_scene(path)
    profile.disable()
    stats = pstats.Stats(profile).stats
    total = sum(t[2] for t in stats.values())  # own time of every function
    parts = {"open_gltf (file, JSON)": ("container.py", "open_gltf"), "accessors": ("container.py", "accessor"),
             "Mesh (checks, normals)": ("mesh.py", "__post_init__"),
             "Scene.bounds (world mesh)": ("scene.py", "bounds"),
             "default environment": ("environment.py", "procedural_environment")}
    result = {name: max((t[3] for (file, _, fn), t in stats.items() if file.endswith(where) and fn == func),
                        default=0.0) for name, (where, func) in parts.items()}
    result["total (profiled)"] = total
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=708, help="quads a side (708: 1,002,528 triangles)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--no-normals", action="store_true", help="leave NORMAL out (computed on load)")
    args = parser.parse_args()
    mesh = heightfield(args.cells)
    scene = Scene(camera=Camera(position=[0, 2, 3]), objects=[SceneObject("terrain", mesh, Diffuse())], lights=[])
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "terrain.glb"
        write_gltf(scene, path)
        if args.no_normals:
            from caustica.scene.gltf.container import open_gltf
            from caustica.scene.gltf.write import glb_bytes

            file = open_gltf(path)
            del file.doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"]
            path.write_bytes(glb_bytes(file.doc, bytes(file.binary)))
        size = path.stat().st_size
        times = timed_loads(path, args.repeat)
        parts = breakdown(path)
    print(json.dumps({
        "triangles": int(len(mesh.faces)), "vertices": int(len(mesh.vertices)), "file_mb": round(size / 1e6, 1),
        "normals_in_file": not args.no_normals, "best_s": round(min(times), 3), "all_s": [round(t, 3) for t in times],
        "breakdown_s": {k: round(v, 3) for k, v in parts.items()},
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
    }, indent=2))


if __name__ == "__main__":
    main()
