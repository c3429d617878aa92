"""per-vertex (Kakimoto et al.) figures: accuracy against exact/env-map/Mitsuba, tessellation, timings.

    .venv/bin/python bench/bench_per_vertex.py [--size 512] [--mitsuba] [--reference-spp 64]

Prints, with the GL renderer string:
1. PSNR (linear, whole image and reflector pixels) of per-vertex and env-map (the paper's
   cube-mapping baseline) against `exact` for the mirror and lens presets; with --mitsuba
   also against the Mitsuba reference.
2. Scalable accuracy: the door mirror's PSNR against `exact` as its tessellation grows.
3. Per-vertex CPU work (rays, least squares, frustum, texture coordinates) and the whole frame
   for 49, ~500 and ~1000 ray-issuing vertices, mirrors and lenses, lens with and without the
   cached refraction vectors, against the env-map frame of the same scene (timed in turns).
4. Reflection map size on the 49-vertex door mirror: the paper's fixed square maps against maps
   sized to the mirror's screen footprint (map_density texels per covered pixel): PSNR against
   exact and the frame time against env-map.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from caustica.metrics import psnr_linear
from caustica.raytrace.embree_scene import ray_scene_for
from caustica.renderer import Renderer
from caustica.scene import presets_per_vertex as presets
from caustica.techniques import per_vertex as pv


def reflector_mask(renderer: Renderer, scene) -> np.ndarray:
    """Pixels where the eye sees a mirror or lens (first hit of the primary rays)."""
    camera = renderer.camera_for(scene)
    origins, dirs = camera.primary_rays(1)
    hits = ray_scene_for(scene).intersect(origins.reshape(-1, 3), dirs.reshape(-1, 3))
    kinds = np.array([o.material.kind in ("mirror", "glass") for o in scene.objects] + [False])
    return kinds[hits.object_index].reshape(camera.size[1], camera.size[0])


def psnr_pair(image, reference, mask) -> tuple[float, float]:
    return psnr_linear(image, reference), psnr_linear(image[mask][None], reference[mask][None])


def median_ms(fn, repeats: int = 7) -> float:
    return interleaved_ms([fn], repeats)[0]


def interleaved_ms(fns, repeats: int = 9) -> list[float]:
    """Median ms of each of ``fns``, timed in turns so that load on the shared cores hits them alike."""
    for fn in fns:
        fn()
    times = [[] for _ in fns]
    for _ in range(repeats):
        for fn, spent in zip(fns, times):
            start = time.perf_counter()
            fn()
            spent.append((time.perf_counter() - start) * 1000.0)
    return [float(np.median(t)) for t in times]


def per_vertex_ms(scene, params) -> tuple[float, int]:
    """Median ms of the CPU per-vertex work of the scene's first reflector, and its ray-issuing vertices."""
    index = next(i for i, o in enumerate(scene.objects) if pv.reflector_kind(o, params))
    camera, ray_scene = scene.camera, ray_scene_for(scene)

    def work():
        return pv.prepare_reflector(scene, index, camera.position, camera.up, ray_scene, params,
                                    camera.view_from_world())

    return median_ms(work, 15), len(work().vertex_ids)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--mitsuba", action="store_true", help="also compare with the Mitsuba reference (slow once)")
    parser.add_argument("--reference-spp", type=int, default=64)
    args = parser.parse_args()
    size = (args.size, args.size)
    renderer = Renderer(size)
    print(f"renderer: {renderer.info().get('renderer')}; {args.size}x{args.size}, 1 spp")

    print("\n1. PSNR dB (whole image / reflector pixels) against exact" + (" and Mitsuba" if args.mitsuba else ""))
    cases = [("door-mirror", presets.door_mirror(size=size), {}), ("mirror-convex", presets.mirror_series(2.0, size=size), {}),
             ("mirror-concave", presets.mirror_series(-2.0, size=size), {}),
             ("saddle-mirror", presets.saddle_mirror(size=size), {}), ("mirror-patches", presets.mirror_patches(size=size), {}),
             ("mirror-in-mirror", presets.mirror_in_mirror(size=size), {"depth": 2}),
             ("spectacle-convex", presets.spectacle_lens(size=size), {}),
             ("spectacle-concave", presets.spectacle_lens(True, 0.6, size=size), {}),
             ("lens-far", presets.spectacle_lens(eye_distance=7.6, chart_distance=2.0, size=size), {}),
             ("aberration-lens", presets.aberration_lens(size=size), {})]
    for name, scene, params in cases:
        mask = reflector_mask(renderer, scene)
        exact = renderer.render(scene, "exact")
        ours = renderer.render(scene, "per-vertex", **params)
        base = renderer.render(scene, "env-map")
        line = (f"  {name:18s} per-vertex {'%.1f / %.1f' % psnr_pair(ours, exact, mask):>13s}   "
                f"env-map {'%.1f / %.1f' % psnr_pair(base, exact, mask):>13s}   patches {pv.LAST_STATS['patches']}")
        if args.mitsuba:
            from caustica.reference import render_reference

            reference = render_reference(scene, size, args.reference_spp)
            line += (f"   vs Mitsuba: per-vertex {'%.1f / %.1f' % psnr_pair(ours, reference, mask)}, "
                     f"env-map {'%.1f / %.1f' % psnr_pair(base, reference, mask)}, "
                     f"exact {'%.1f / %.1f' % psnr_pair(exact, reference, mask)}")
        print(line)

    print("\n2. Scalable accuracy: door mirror, PSNR dB against exact (whole / mirror pixels)")
    for resolution in (2, 4, 6, 12, 24, 48):
        scene = presets.door_mirror(resolution=resolution, size=size)
        mask = reflector_mask(renderer, scene)
        ours = renderer.render(scene, "per-vertex")
        print(f"  {(resolution + 1) ** 2:5d} vertices  {'%.1f / %.1f' % psnr_pair(ours, renderer.render(scene, 'exact'), mask)}")

    print("\n3. Timings, ms (median): per-vertex CPU work; whole per-vertex frame; env-map frame")
    timing = [(f"door mirror res {r}", presets.door_mirror(resolution=r, size=size), {}) for r in (6, 21, 31)]
    for rings, segments in ((6, 16), (10, 40), (14, 56)):
        for cache in (False, True):
            timing.append((f"lens {rings}x{segments}{' cached' if cache else ''}",
                           presets.spectacle_lens(rings=rings, segments=segments, size=size), {"cache": cache}))
    timing.append(("aberration lens", presets.aberration_lens(size=size), {"ior_rgb": presets.ABERRATION_IOR_RGB}))
    timing.append(("aberration cached", presets.aberration_lens(size=size),
                   {"ior_rgb": presets.ABERRATION_IOR_RGB, "cache": True}))
    for name, scene, params in timing:
        work, count = per_vertex_ms(scene, pv.PerVertexParams(**params))
        frame, base = interleaved_ms([lambda: renderer.render_timed(scene, "per-vertex", **params),
                                      lambda: renderer.render_timed(scene, "env-map")])
        print(f"  {name:24s} {count:5d} ray vertices   work {work:6.2f}   frame {frame:7.1f}   env-map {base:6.1f}"
              f"   ratio {frame / base:4.1f}")

    print("\n4. Reflection map size, door mirror (49 vertices): PSNR dB against exact (whole / mirror), frame / env-map")
    scene = presets.door_mirror(size=size)
    mask, exact = reflector_mask(renderer, scene), renderer.render(scene, "exact")
    for params in ({"map_size": 256}, {"map_size": 512}, {"map_density": 0.25}, {"map_density": 0.5},
                   {"map_density": 1.0}, {"map_density": 2.0}):
        ours = renderer.render(scene, "per-vertex", **params)
        maps = [pv.map_texels(renderer.camera_for(scene), r.points, p, pv.PerVertexParams(**params))
                for r in pv.LAST_STATS["reflectors"] for p in r.patches]
        frame, base = interleaved_ms([lambda: renderer.render_timed(scene, "per-vertex", **params),
                                      lambda: renderer.render_timed(scene, "env-map")])
        label = ", ".join(f"{k} {v}" for k, v in params.items())
        print(f"  {label:18s} map {' + '.join(f'{w}x{h}' for w, h in maps):12s} {'%.1f / %.1f' % psnr_pair(ours, exact, mask):>13s}"
              f"   frame {frame:6.1f}   env-map {base:5.1f}   ratio {frame / base:4.2f}")


if __name__ == "__main__":
    main()
