"""per-vertex (Kakimoto et al.) figures: accuracy against exact/env-map/Mitsuba, tessellation, timings.

    .venv/bin/python bench/bench_per_vertex.py [--size 512] [--mitsuba] [--reference-spp 64]
    .venv/bin/python bench/bench_per_vertex.py --curved [--width 256 --height 192]

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

``--curved`` (issue 22 part 4) prints only: a 33 x 33 convex mirror reflecting black, white and coloured
boxes 0.5 to 2 units away (:func:`curved_mirror_scene`: a point light, a black environment, so that the
diffuse shading is the same in the oracle and the raster), seen from three cameras. Against `exact` at
16 spp (no photons, the unoccluded SH: environment_samples 0) on the mirror's pixels (its labels) and
on the whole image: per-vertex as it was before issue 22 part 4 (``PAPER``), with today's defaults and
refined; the brightest pixel two pixels inside the rim's band where the exact rays escape (to black);
per-vertex at 16 spp off the mirror (the diffuse shading match); the frame's ms against `plain`, with the
per-vertex work traced anew (camera moved) and kept (still camera), medians in turns.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from caustica.metrics import psnr_linear
from caustica.per_vertex.preparation import reflector_kind
from caustica.raytrace.embree_scene import ray_scene_for
from caustica.renderer import Renderer
from caustica.scene import Camera, Diffuse, PointLight, Scene, SceneObject, procedural_environment
from caustica.scene import presets_per_vertex as presets
from caustica.scene.shapes import box, plane
from caustica.scene.transform import Transform
from caustica.techniques import per_vertex as pv

# Per-vertex as Kakimoto et al. and this project had it before issue 22 part 4 (the same images): patches
# split by their field of view alone, maps at half a texel per covered pixel.
PAPER = {"map_density": 0.5, "split_hidden": 1.0}
BLACK, WHITE = (0.02, 0.02, 0.02), (0.95, 0.95, 0.95)
CURVED_BOXES = [((-0.85, -0.2, 0.6), (0.3, 0.8, 0.3), BLACK), ((0.85, -0.25, 0.5), (0.25, 0.7, 0.25), WHITE),
                ((-0.35, -0.45, 1.1), (0.3, 0.3, 0.3), (0.9, 0.1, 0.1)), ((0.3, -0.45, 0.9), (0.25, 0.3, 0.25), BLACK),
                ((-0.8, 0.55, 1.0), (0.3, 0.3, 0.3), (0.1, 0.3, 0.95)), ((0.75, 0.6, 1.2), (0.35, 0.35, 0.35), (0.1, 0.8, 0.15)),
                ((0.0, 0.75, 0.8), (0.3, 0.2, 0.3), WHITE), ((0.5, -0.35, 1.8), (0.3, 0.5, 0.3), (0.95, 0.85, 0.1)),
                ((-0.6, -0.3, 2.0), (0.3, 0.6, 0.3), WHITE)]
CURVED_CAMERAS = [(0.15, 0.1, 2.2), (-1.0, 0.45, 1.9), (1.1, -0.15, 1.8)]


def curved_mirror_scene(camera: int = 0, radius: float = 2.0, size=(256, 192)) -> Scene:
    """A 1 x 1 spherical mirror of 33 x 33 vertices (curvature radius ``radius``) at the origin facing +Z,
    boxes around it, a floor and a wall behind the camera; ``camera`` one of CURVED_CAMERAS."""
    mirror = presets.mirror_object("mirror", presets.curved_mirror(1.0, 1.0, radius, 32), [0, 0, 0], [0, 0, 1])
    objects = [mirror, SceneObject("floor", plane((8.0, 8.0)), Diffuse(color=[0.5, 0.5, 0.5]), Transform(position=[0, -0.6, 1.5])),
               SceneObject("wall", plane((8.0, 4.0)), Diffuse(color=[0.8, 0.8, 0.8]),
                           Transform(position=[0, 1.4, 3.0], rotation=[-90, 0, 0]))]
    for k, (position, extent, colour) in enumerate(CURVED_BOXES):
        objects.append(SceneObject(f"box-{k}", box(extent), Diffuse(color=list(colour)), Transform(position=list(position))))
    view = Camera(position=list(CURVED_CAMERAS[camera]), look_at=[0, 0, 0], fov_y=36.0, size=size)
    return Scene(camera=view, objects=objects, lights=[PointLight(position=[0.3, 2.0, 2.0], intensity=[12, 12, 12])],
                 environment=procedural_environment("black"), name=f"curved-mirror-{camera}")


def curved_reference(renderer: Renderer, scene, spp: int = 16):
    """`exact` without photons and with the SH ambient the raster has; (image, mirror mask, escape mask):
    the pixels whose centre ray meets the mirror, and those of them whose reflected ray escapes."""
    image, layers = renderer.render(scene, "exact", spp=spp, caustic_photons=0, environment_samples=0, labels=["id"])
    mirror = layers["id"] == 0
    camera = renderer.camera_for(scene)
    origins, dirs = camera.primary_rays(1)
    ray_scene = ray_scene_for(scene)
    first = ray_scene.intersect(origins.reshape(-1, 3), dirs.reshape(-1, 3))
    on = first.object_index == 0
    d = dirs.reshape(-1, 3)[on]
    n = first.normal[on]
    reflected = d - 2.0 * np.sum(d * n, axis=1, keepdims=True) * n
    escape = np.zeros(len(first.hit), bool)
    escape[np.nonzero(on)[0]] = ~ray_scene.intersect(first.position[on], reflected).hit
    return image, mirror, escape.reshape(mirror.shape) & mirror


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
    index = next(i for i, o in enumerate(scene.objects) if reflector_kind(o, params))
    camera, ray_scene = scene.camera, ray_scene_for(scene)

    def work():
        return pv.prepare_reflector(scene, index, camera.position, camera.up, ray_scene, params,
                                    camera.view_from_world())

    return median_ms(work, 15), len(work().vertex_ids)


def curved(width: int, height: int, radius: float) -> None:
    """Issue 22 part 4: the curved mirror scene from three cameras (see the module's docstring)."""
    from scipy.ndimage import binary_erosion

    renderer = Renderer((width, height))
    print(f"renderer: {renderer.info().get('renderer')}; {width}x{height}; curvature radius {radius:g}; "
          "exact 16 spp without photons")
    configs = [("paper", PAPER), ("default", {}), ("refined", {"refine": 0.5})]
    print("mirror pixels dB: per-vertex 1 spp vs exact 16 / vs exact 1 spp / per-vertex 16 spp vs exact 16;"
          " whole image 1 spp; patches; brightest pixel two pixels inside the rim where the exact rays escape")
    for camera in range(len(CURVED_CAMERAS)):
        scene = curved_mirror_scene(camera, radius, (width, height))
        exact, mirror, escape = curved_reference(renderer, scene)
        escape = binary_erosion(escape, iterations=2)
        exact1, _, _ = curved_reference(renderer, scene, 1)
        for name, params in configs:
            ours = renderer.render(scene, "per-vertex", **params)
            patches = pv.LAST_STATS["patches"]
            fine = renderer.render(scene, "per-vertex", spp=16, **params)
            line = (f"  camera {camera} {name:8s} {psnr_linear(ours, exact, mirror):5.1f} / {psnr_linear(ours, exact1, mirror):5.1f}"
                    f" / {psnr_linear(fine, exact, mirror):5.1f}   whole {psnr_linear(ours, exact):5.1f}   patches {patches}"
                    f"   rim max {float(ours[escape].max()) if escape.any() else 0.0:.3f}")
            if name == "default":
                line += f"   off the mirror at 16 spp {psnr_linear(fine, exact, ~mirror):5.1f}"
            print(line)
    print("frame ms (median of 9, in turns): plain; per-vertex traced anew (camera moved) / kept (still camera)")
    for camera in range(len(CURVED_CAMERAS)):
        scene = curved_mirror_scene(camera, radius, (width, height))
        fns = [lambda: renderer.render_timed(scene, "plain")]
        for _, params in configs:
            fns += [lambda p=params: (pv._REFLECTORS.clear(), renderer.render_timed(scene, "per-vertex", **p)),
                    lambda p=params: renderer.render_timed(scene, "per-vertex", **p)]
        times = interleaved_ms(fns)
        cells = "   ".join(f"{name} {times[1 + 2 * k]:5.1f} / {times[2 + 2 * k]:5.1f}" for k, (name, _) in enumerate(configs))
        print(f"  camera {camera}  plain {times[0]:5.1f}   {cells}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--curved", action="store_true", help="only the curved mirror of issue 22 part 4")
    parser.add_argument("--width", type=int, default=256, help="--curved: image width")
    parser.add_argument("--height", type=int, default=192, help="--curved: image height")
    parser.add_argument("--radius", type=float, default=2.0, help="--curved: the mirror's curvature radius")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--mitsuba", action="store_true", help="also compare with the Mitsuba reference (slow once)")
    parser.add_argument("--reference-spp", type=int, default=64)
    args = parser.parse_args()
    if args.curved:
        curved(args.width, args.height, args.radius)
        return
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
