"""Ground-truth images from Mitsuba 3: a composite of the ``path`` and ``ptracer`` integrators.

:func:`render_reference` exports the scene (:mod:`caustica.reference.mitsuba_export`),
renders it with Mitsuba and returns a (H, W, 3) float32 linear image, row 0 at
the top, cached on disk.

Why two integrators. Mitsuba 3 has no bidirectional or photon-mapping
integrator. ``path`` (``volpath`` when a glass absorbs) is right for what the
camera sees directly and through glass and mirrors, but it cannot find a
caustic cast by a point (delta) light through a specular surface onto a
diffuse one: that path has no vertex a camera path can connect to the light
from. ``ptracer`` traces from the emitters and connects each diffuse vertex to
the camera, so it gets those caustics, but it cannot see specular surfaces.
Measured on ``caustic-sphere`` (96x96, 256 spp): glass pixels come out black
(mean 2e-5 against 0.5 with ``path``); the directly seen environment is right
on average but noisy (ptracer splats it by sampling the emitter); and the floor
lit by the environment is very noisy (environment light paths start on a disk
the size of the scene and the sun is small), far noisier than ``path``, which
samples the environment towards each shading point.

The composite therefore splits the emitters (light transport is linear in
them). With ``c`` the fraction of a pixel's box-filter footprint whose primary
ray first hits a diffuse surface (16 stratified rays a pixel, traced with our
Embree :class:`~caustica.raytrace.embree_scene.RayScene`):

    reference = path[environment] + (1 - c) * path[lights] + c * ptracer[lights]

``path[environment]`` (only the environment emitter) holds everything lit by
the environment, its caustics included (``path`` finds those by BSDF sampling);
the light part comes from ``ptracer`` on purely diffuse pixels (direct light
and caustics) and from ``path`` on pixels without any diffuse surface. At a
mixed pixel only the light part blends: at an edge between a diffuse surface
and the background the error is -c (1 - c) times the caustic radiance there;
at an edge between a diffuse surface and glass or a mirror the light-lit
radiance seen in the specular part is also under-weighted by c (1 - c), at
most a quarter of it at c = 1/2 (``ptracer`` draws it black). The simpler
``ptracer + (1 - c) * path`` with all emitters would count the directly seen
environment twice at every diffuse/background edge and bring ptracer's
environment noise onto every diffuse pixel, which is why it was not chosen.
When the scene has no lights, or no pixel sees a diffuse surface, only
``path`` runs; when it has no environment light, ``path[environment]`` is
skipped.

The one part neither integrator gives: a point-light caustic seen *through*
glass or in a mirror (light -> specular -> diffuse -> specular -> camera).
``path`` cannot connect it to the light and ``ptracer`` cannot connect it
to the camera, so it is missing from the reference (environment-lit caustics
are not affected: ``path`` finds those by sampling).

Other limits: ``ptracer`` ignores participating media (its image is the same
with and without the glass's medium), so light caustics through absorbing glass
are not attenuated on purely diffuse pixels (:func:`reference_caveats` says so); spot
lights use Mitsuba's linear-in-angle falloff (see the export module);
dispersive glass (per-channel IOR) costs three times as much, one composite
per channel keeping that channel.

Variants: ``llvm_ad_rgb`` (vectorised on every core through LLVM) when it
initialises, else ``scalar_rgb`` with a warning. Samples are split into
passes with different seeds and averaged, with progress on stderr (:mod:`caustica.progress`).

Cache: results are stored as .npy under ``cache_dir`` (default
``$CAUSTICA_CACHE`` or ``~/.cache/caustica/reference``), keyed by a hash of the
geometry, transforms, materials, lights, environment image, camera, size,
spp, integrator settings, variant and :data:`REFERENCE_VERSION`; writes are
atomic.
"""
from __future__ import annotations

import hashlib
import json
import math
import re
import time
import warnings
from pathlib import Path

import numpy as np

from ..cache import cache_dir, load_array, slug, store_array
from ..errors import ReferenceUnavailableError, first_line
from ..progress import progress as progress_display
from ..raytrace.environment_bake import without_standing_faces
from ..scene.scene import recentred
from .mitsuba_export import has_absorbing_glass, has_dispersion, image_hash, mesh_file_hash, scene_to_mitsuba

REFERENCE_VERSION = "1"
PREFERRED_VARIANT = "llvm_ad_rgb"
FALLBACK_VARIANT = "scalar_rgb"
COVERAGE_SPP = 16
_warned_fallback = False


def mitsuba_module(variant: str | None = None):
    """Import Mitsuba and set ``variant`` (default: llvm_ad_rgb, else scalar_rgb with a warning)."""
    global _warned_fallback
    try:
        import mitsuba as mi
    except ImportError:
        raise ReferenceUnavailableError(
            "the Mitsuba reference needs the 'reference' extra: pip install 'caustica[reference]'"
        ) from None
    if variant is not None:
        try:
            mi.set_variant(variant)
        except Exception as exc:
            raise ReferenceUnavailableError(
                f"Mitsuba variant '{variant}' is unavailable ({first_line(exc)}); choose one of {', '.join(mi.variants())}"
            ) from None
        return mi
    try:
        mi.set_variant(PREFERRED_VARIANT)
    except Exception as exc:
        if not _warned_fallback:
            warnings.warn(
                f"Mitsuba variant {PREFERRED_VARIANT} failed to initialise ({first_line(exc)}); "
                f"rendering the reference with {FALLBACK_VARIANT}, which is much slower",
                stacklevel=3,
            )
            _warned_fallback = True
        mi.set_variant(FALLBACK_VARIANT)
    return mi


def default_cache_dir() -> Path:
    return cache_dir("reference")


def reference_file_name(scene, camera, spp: int, seed: int, key: str) -> str:
    """The cache file of one reference: the hash ``key`` says what it holds; the scene name appears only as a
    slug (no separators, no '..': a name like '../../x' stays inside the cache folder). Preset names are
    their own slugs, so caches written before keep their names."""
    seed_tag = f"-seed{int(seed)}" if seed else ""  # seed 0 keeps the names existing caches have
    return f"{slug(scene.name)}-{camera.size[0]}x{camera.size[1]}-{int(spp)}spp{seed_tag}-{key}.npy"


def _legacy_file(cache_dir: Path, path: Path, name: str) -> list[Path]:
    """The name a reference had before slugs (the raw scene name, e.g. 'sphere-ior-1.5'), where that name
    was a plain file name: existing caches stay readable."""
    if name == slug(name) or not re.fullmatch(r"[A-Za-z0-9_.-]{1,80}", name) or ".." in name:
        return []
    return [cache_dir / (name + path.name[len(slug(name)):])]


def diffuse_coverage(scene, camera, spp: int = COVERAGE_SPP) -> np.ndarray:
    """(H, W) fraction of each pixel's footprint whose primary ray first hits a diffuse surface."""
    from ..raytrace.embree_scene import ray_scene_for

    if not scene.objects:
        return np.zeros(camera.size[::-1])
    origins, dirs = camera.primary_rays(spp)
    height, width, samples = dirs.shape[:3]
    hits = ray_scene_for(scene).intersect(origins.reshape(-1, 3), dirs.reshape(-1, 3))
    is_diffuse = np.array([o.material.kind == "diffuse" for o in scene.objects] + [False])
    return is_diffuse[hits.object_index].reshape(height, width, samples).mean(axis=2)


def _round(x) -> list:
    return [float(f"{v:.9g}") for v in np.asarray(x, dtype=np.float64).reshape(-1)]


def _material_value(key: str, value):
    """A material field as the cache key holds it: a texture (any ``*texture`` field) by its hash, numbers
    rounded."""
    if isinstance(value, str):
        return value
    return image_hash(value) if key.endswith("texture") else _round(value)


def cache_key(scene, camera, spp: int, max_depth: int, variant: str, analytic_spheres: bool) -> str:
    """Hash of everything the reference image depends on."""
    desc = {
        "version": REFERENCE_VERSION,
        "variant": variant,
        "spp": int(spp),
        "max_depth": int(max_depth),
        "analytic_spheres": bool(analytic_spheres),
        "coverage_spp": COVERAGE_SPP,
        "camera": [_round(camera.position), _round(camera.look_at), _round(camera.up),
                   _round([camera.fov_y, camera.near, camera.far]), list(camera.size)],
        "objects": [
            {
                "mesh": mesh_file_hash(o.mesh),
                "sphere": None if getattr(o.mesh, "analytic_sphere", None) is None
                else [_round(o.mesh.analytic_sphere[0]), _round(o.mesh.analytic_sphere[1])],
                "transform": _round(o.world_from_object()),
                "material": {k: _material_value(k, v) for k, v in sorted(vars(o.material).items())
                             if v is not None and not k.startswith("_")} | {"kind": o.material.kind},
            }
            for o in scene.objects
        ],
        "lights": [
            {k: _round(v) for k, v in sorted(vars(light).items())} | {"kind": light.kind} for light in scene.lights
        ],
        "environment": image_hash(scene.environment.image),
        "intensity_scale": float(scene.intensity_scale),
    }
    return hashlib.sha1(json.dumps(desc, sort_keys=True).encode()).hexdigest()[:24]


def _passes(spp: int) -> list[int]:
    """Split ``spp`` into passes of at most 64 samples (at least 4 passes from 16 spp up)."""
    n = max(math.ceil(spp / 64), min(4, spp // 4), 1)
    base, extra = divmod(spp, n)
    return [base + (1 if i < extra else 0) for i in range(n)]


def reference_caveats(scene) -> list[str]:
    """What this scene's reference gets wrong by construction (printed beside comparisons)."""
    caveats = []
    kinds = {o.material.kind for o in scene.objects}
    lit = any(np.any(np.asarray(light.intensity) > 0) for light in scene.lights)
    if lit and "diffuse" in kinds and kinds & {"glass", "mirror"}:
        # The module docstring: light -> specular -> diffuse -> specular -> camera has no path either integrator
        # samples (env-mixed-light-low: exact without its photons matches the reference on the glass pixels).
        caveats.append("the lights' caustics seen through glass or in mirrors are missing (neither path nor ptracer "
                       "samples light -> specular -> diffuse -> specular -> camera)")
    if scene.lights and has_absorbing_glass(scene):
        # Measured (tests/test_reference.py): ptracer's image is bit-identical with and without the medium.
        caveats.append("caustics through absorbing glass are not attenuated (Mitsuba's ptracer ignores media)")
    return caveats


def planned_renders(scene, coverage: np.ndarray) -> list[tuple[str, str]]:
    """The (integrator, emitters) renders the composite needs (see the module docstring)."""
    has_env = bool(np.any(scene.environment.image > 0))
    if not scene.lights or not coverage.any():
        return [("path", "all")]
    renders = [("path", "environment")] if has_env else []
    return renders + [("path", "lights"), ("ptracer", "lights")]


def composite_weights(coverage: np.ndarray) -> dict:
    """Each (integrator, emitters) render's per-pixel weight in the composite (the module docstring)."""
    c = coverage[..., None].astype(np.float32)
    return {("path", "all"): 1.0, ("path", "environment"): 1.0, ("path", "lights"): 1.0 - c, ("ptracer", "lights"): c}


def prepared(scene, camera=None, size=None):
    """(scene, camera) as the reference renders them: moved to the origin where far (Mitsuba's float32
    variants), glass standing on a receiver without its faces on it (exact traces it so; Mitsuba would meet
    them coplanar with the receiver and resolve them face by face, in stripes), ``camera`` (default the
    scene's) moved along and at ``size`` (width, height) when given."""
    scene, shift = recentred(scene)
    scene = without_standing_faces(scene)
    camera = camera.translated(shift) if camera is not None else scene.camera
    return scene, camera if size is None else camera.with_size(*size)


def first_and_fastest(call, repeats: int = 1, clock=time.perf_counter):
    """(result, first seconds, fastest seconds) of ``call()`` run 1 + ``repeats`` times: the first call
    pays what a cold call pays (Dr.Jit compiles kernels for a new sample count) and is kept apart; the
    fastest of the later ones, the least disturbed by other work on shared cores, is the render's own time.
    ``result`` is the last call's."""
    start = clock()
    call()
    first = clock() - start
    fastest, result = float("inf"), None
    for _ in range(max(1, repeats)):
        start = clock()
        result = call()
        fastest = min(fastest, clock() - start)
    return result, first, fastest


class LoadedReference:
    """The composite's Mitsuba scenes loaded once, to time Mitsuba as its users run it: only
    ``mi.render`` of a loaded scene, and only the integrators an image region needs (a caustic region of
    purely diffuse pixels needs the light tracer and the environment's path, not the lights' path).

    ``setup_seconds``: what loading took (the coverage trace, the export and ``mi.load_dict`` of each
    render); nothing is rendered before the first ``render``, whose first calls at each spp pay the JIT's
    compilation (and, the first time, its start), as a cold run does. ``render(spp, seed)`` returns the composite image and, per render,
    its seconds and the first (compiling) call's, ``last_first_seconds``. The scene is the one
    :func:`render_reference` renders (:func:`prepared`)."""

    def __init__(self, scene, size=None, variant: str | None = None, max_depth: int = 16,
                 analytic_spheres: bool = True, clock=time.perf_counter):
        start = clock()
        self.clock = clock
        self.mi = mi = mitsuba_module(variant)
        scene, self.camera = prepared(scene, size=size)
        coverage = diffuse_coverage(scene, self.camera)
        self.weights = composite_weights(coverage)
        self.renders = planned_renders(scene, coverage)
        self.channels = [0, 1, 2] if has_dispersion(scene) else [None]
        mesh_dir = default_cache_dir() / "meshes"
        self.scenes = {}
        for channel in self.channels:
            for integrator, emitters in self.renders:
                self.scenes[channel, integrator, emitters] = mi.load_dict(scene_to_mitsuba(
                    scene, spp=1, integrator=integrator, max_depth=max_depth, mesh_dir=mesh_dir, channel=channel,
                    camera=self.camera, analytic_spheres=analytic_spheres, emitters=emitters))
        self.setup_seconds = clock() - start
        self.last_first_seconds: dict = {}

    def render(self, spp: int, seed: int = 1, repeats: int = 1) -> tuple[np.ndarray, dict]:
        """The composite at ``spp`` samples (one pass per render) and {(integrator, emitters): seconds}, each
        the fastest of ``repeats`` calls after a first one at this spp (:func:`first_and_fastest`): Dr.Jit
        compiles kernels anew for a new sample count, which a user rendering at one setting pays once. The
        first calls' seconds go to ``last_first_seconds``, keyed alike."""
        seconds: dict = {}
        first_seconds: dict = {}

        def timed(channel, k, integrator, emitters) -> np.ndarray:
            loaded = self.scenes[channel, integrator, emitters]
            seed_value = 1000 * k + 100_000 * int(seed)
            part, first, fastest = first_and_fastest(
                lambda: np.array(self.mi.render(loaded, spp=spp, seed=seed_value), dtype=np.float64)[..., :3],
                repeats, self.clock)
            key = integrator, emitters
            seconds[key] = seconds.get(key, 0.0) + fastest
            first_seconds[key] = first_seconds.get(key, 0.0) + first
            return part.astype(np.float32)

        image = _composite(self.camera.size, self.channels, self.renders, self.weights, timed)
        self.last_first_seconds = first_seconds
        return image, seconds


def _composite(size, channels, renders, weights, part) -> np.ndarray:
    """The composite (H, W, 3) float32: for each channel pass (None: one pass for all three), the sum over
    ``renders`` of their ``weights`` times ``part(channel, k, integrator, emitters)``, keeping that channel."""
    width, height = size
    result = np.zeros((height, width, 3), np.float32)
    for channel in channels:
        image = np.zeros_like(result)
        for k, (integrator, emitters) in enumerate(renders):
            image += weights[integrator, emitters] * part(channel, k, integrator, emitters)
        if channel is None:
            result = image
        else:
            result[..., channel] = image[..., channel]
    return result


def _render_integrator(mi, scene, camera, spp, integrator, emitters, max_depth, mesh_dir, channel, analytic_spheres,
                       bar, seed_base) -> np.ndarray:
    """Average of ``spp`` samples of one integrator, over several seeded passes."""
    scene_dict = scene_to_mitsuba(scene, spp=spp, integrator=integrator, max_depth=max_depth, mesh_dir=mesh_dir,
                                  channel=channel, analytic_spheres=analytic_spheres, camera=camera,
                                  emitters=emitters)
    mscene = mi.load_dict(scene_dict)
    total = None
    for i, pass_spp in enumerate(_passes(spp)):
        image = np.array(mi.render(mscene, spp=pass_spp, seed=seed_base + i), dtype=np.float64)[..., :3]
        total = image * pass_spp if total is None else total + image * pass_spp
        if bar is not None:
            bar.update(pass_spp)
    return (total / spp).astype(np.float32)


def render_reference(
    scene,
    size: tuple[int, int] | None = None,
    spp: int = 256,
    cache_dir: str | Path | None = None,
    progress: bool = True,
    variant: str | None = None,
    max_depth: int = 16,
    cache: bool = True,
    analytic_spheres: bool = True,
    camera=None,
    seed: int = 0,
) -> np.ndarray:
    """The Mitsuba ground truth of ``scene``: (H, W, 3) float32 linear RGB, row 0 at the top.

    ``size`` (width, height) overrides the camera's (``camera`` replaces the
    scene's); ``spp`` samples per pixel for each integrator; ``max_depth`` is
    Mitsuba's path length limit; ``seed`` selects independent sample sequences
    (renders with different seeds share no samples). See the module docstring
    for the composite.
    """
    spp = int(spp)
    if spp < 1:
        raise ValueError(f"samples per pixel {spp} must be at least 1")
    mi = mitsuba_module(variant)
    active = mi.variant()
    scene, camera = prepared(scene, camera, size)
    cache_dir = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    key = cache_key(scene, camera, spp, max_depth, active, analytic_spheres)
    path = cache_dir / reference_file_name(scene, camera, spp, seed, key)
    if cache:
        for candidate in (path, *_legacy_file(cache_dir, path, scene.name)):
            cached = load_array(candidate)
            if cached is not None:
                return cached  # a missing or damaged entry renders again

    coverage = diffuse_coverage(scene, camera)
    renders = planned_renders(scene, coverage)
    channels = [0, 1, 2] if has_dispersion(scene) else [None]
    mesh_dir = cache_dir / "meshes"

    with progress_display(spp * len(renders) * len(channels), f"mitsuba {scene.name}", unit="spp",
                          enabled=progress) as bar:
        def rendered(channel, k, integrator, emitters) -> np.ndarray:
            label = f"{integrator}[{emitters}]"
            bar.set_postfix_str(label if channel is None else f"{label} channel {channel}")
            return _render_integrator(mi, scene, camera, spp, integrator, emitters, max_depth, mesh_dir, channel,
                                      analytic_spheres, bar, seed_base=1000 * k + 100_000 * int(seed))

        result = _composite(camera.size, channels, renders, composite_weights(coverage), rendered)
    result = np.ascontiguousarray(result, dtype=np.float32)
    if cache:
        store_array(path, result)
    return result

