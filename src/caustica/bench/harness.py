"""``caustica bench``: speed of every technique, and its time-to-quality against Mitsuba.

Per scene, size and technique: the median ms per frame, per-pass ms (GPU timer
queries on a GPU, finish() and wall clock on llvmpipe), triangle count, and
the ratio to a ``plain`` diffuse frame of the same scene in the same run.
Time to quality: each technique's relMSE against the high-sample reference
per region (whole image, refractor, caustic, rest, and the glints apart: a
point light's image that the path-traced reference cannot contain), the
reference's own noise floor there, then Mitsuba at 1, 2, 4, ... spp timed on
the same machine; the spp and seconds Mitsuba needs to match the technique's
error over the pixels the reference can contain (and over the caustic region)
give the speed ratio. Mitsuba's figures are labelled: ``render`` is mi.render
of loaded, compiled scenes; ``end to end`` adds the export, load and the first,
compiling call, and is never less than ``render``.
"""
from __future__ import annotations

import numpy as np

from ..atomic import write_atomic
from ..renderer import Renderer
from ..techniques import get_technique
from .timing import end_to_end_seconds, steps, timed_render


def triangle_count(scene) -> int:
    return int(sum(len(o.mesh.faces) for o in scene.objects))


def speed_rows(scene, techniques, sizes, frames, log=print) -> list[dict]:
    """One row per (size, technique): ms, ratio to plain, per-pass ms."""
    rows = []
    with steps(len(sizes) * len(techniques), f"bench {scene.name}", "renders") as bar:
        for size in sizes:
            renderer = Renderer((size, size))
            _, plain_ms = timed_render(renderer, scene, "plain", 1, frames)
            profiler = Renderer((size, size), profile_passes=True)
            for name in techniques:
                bar.set_postfix_str(f"{name} {size}^2")
                _, ms = timed_render(renderer, scene, name, 1, frames if get_technique(name).uses_gl else 1)
                pass_ms = {}
                if get_technique(name).uses_gl:
                    profiler.render(scene, name)
                    profiler.render(scene, name)
                    pass_ms = profiler.last_pass_ms
                row = {"scene": scene.name, "size": size, "technique": name, "ms": ms, "plain_ms": plain_ms,
                       "ratio_to_plain": ms / plain_ms, "pass_ms": pass_ms, "triangles": triangle_count(scene),
                       "renderer": renderer.info()["renderer"] if get_technique(name).uses_gl else "CPU (Embree)"}
                rows.append(row)
                bar.update()
                log(f"{scene.name:16s} {size:5d}^2 {name:12s} {ms:9.2f} ms  x{ms / plain_ms:5.2f} plain  "
                    + " ".join(f"{k} {v:.1f}" for k, v in pass_ms.items()) + f"  [{row['renderer']}]")
    return rows


def mitsuba_curve(scene, size, errors, caustic=None, max_spp=256, seed=1, repeats=1, log=print) -> list[dict]:
    """Mitsuba's error against time on this machine, one point per spp in 1, 2, 4, ... ``max_spp``, from the
    composite's scenes loaded once (reference/render.py LoadedReference): ``seconds``, the render alone (``mi.render``
    of loaded scenes, after a first call at that spp that compiles); ``end_to_end_seconds``, a cold run from the
    scene (bench.timing.end_to_end_seconds: the export and load, then that first call; never less than
    ``seconds``); with ``caustic``, an (H, W) mask, ``seconds_caustic`` and ``end_to_end_seconds_caustic``: the
    same over only the renders whose weight reaches those pixels (the light tracer and the environment's path, not
    the lights' path, on purely diffuse pixels); and ``errors(image)``, a dict. ``seed``: pick one the reference
    did not use, so its error is not underestimated. ``size`` is (width, height); ``repeats``:
    LoadedReference.render's (the fastest of that many calls)."""
    from ..reference.render import LoadedReference

    loaded = LoadedReference(scene, size)
    caustic_renders = [key for key, weight in loaded.weights.items() if key in loaded.renders
                       and (np.isscalar(weight) or np.any(np.asarray(weight)[caustic] > 0))] \
        if caustic is not None and caustic.any() else []
    curve = []
    counts = [1 << k for k in range(max_spp.bit_length())]
    with steps(len(counts), f"mitsuba {scene.name} time to quality", "spp counts") as bar:
        for spp in counts:
            bar.set_postfix_str(f"{spp} spp")
            image, seconds = loaded.render(spp, seed=seed, repeats=repeats)
            first = loaded.last_first_seconds

            def timing(keys) -> tuple[float, float]:
                renders = [seconds[key] for key in keys]
                return sum(renders), end_to_end_seconds(loaded.setup_seconds, [first[key] for key in keys], renders)

            point = {"spp": spp, **dict(zip(("seconds", "end_to_end_seconds"), timing(list(seconds))))}
            point.update(errors(image))
            if caustic_renders:
                point.update(zip(("seconds_caustic", "end_to_end_seconds_caustic"), timing(caustic_renders)))
            curve.append(point)
            bar.update()
            log(f"  mitsuba {spp:4d} spp: {timing_label(point, '')}"
                + (f"; caustic region's renders: {timing_label(point, '_caustic')}" if caustic_renders else "")
                + "; " + ", ".join(f"{k} {v:.5f}" for k, v in point.items() if "relmse" in k))
    return curve


def timing_label(point: dict, suffix: str) -> str:
    """A Mitsuba curve point's timing, labelled: the render alone and end to end (``suffix`` '_caustic': of the
    caustic region's renders; where the point has none, the whole composite's)."""
    if "seconds" + suffix not in point:
        suffix = ""
    return (f"render {point['seconds' + suffix]:.2f} s (loaded and compiled), "
            f"end to end {point['end_to_end_seconds' + suffix]:.2f} s (export, load and compile included)")


def first_reaching(curve: list[dict], key: str, error: float) -> dict | None:
    """The first point of a :func:`mitsuba_curve` whose ``key`` error is at most ``error``; None if none is."""
    return next((c for c in curve if c[key] <= error), None)


def speed_text(ratio: float) -> str:
    """A technique's speed against Mitsuba's (``ratio``: Mitsuba's seconds over the technique's), in words: 'x219
    faster', 'x3.2 faster', 'x3.2 slower' (a ratio under 1 is not 'x0 faster')."""
    if ratio >= 1.0:
        return f"x{ratio:.0f} faster" if ratio >= 10.0 else f"x{ratio:.1f} faster"
    return f"x{1.0 / ratio:.1f} slower" if ratio > 0.1 else f"x{1.0 / ratio:.0f} slower"


QUALITY_REGIONS = ("all", "contained", "glint", "refractor", "caustic", "rest")
# The errors Mitsuba's needed spp is based on, with the suffix of their entries: the pixels the reference can
# contain (the glints apart), and the caustic region.
NEEDED_FROM = {"contained_relmse": "", "caustic_relmse": "_caustic"}


def error_key(region: str) -> str:
    """The key of a region's relMSE in time-to-quality's entries and curve points ('relmse' for the whole image)."""
    return "relmse" if region == "all" else f"{region}_relmse"


def quality_masks(scene, camera, reference, images) -> dict:
    """{region: (H, W) bool or None (all)} of QUALITY_REGIONS: ``glint`` (caustica.metrics.regions.glint_mask of
    the technique ``images``: a point light's image the reference cannot contain), ``contained``, every other
    pixel, and region_masks's refractor and rest and caustic_region's caustic pixels, each without the glints."""
    from ..metrics import caustic_region, region_masks
    from ..metrics.regions import glint_mask

    regions = region_masks(scene, camera)
    glint = glint_mask(scene, camera, images, reference)
    contained = ~glint
    return {"all": None, "contained": contained, "glint": glint, "refractor": regions["refractor"] & contained,
            "caustic": caustic_region(scene, camera) & contained, "rest": regions["rest"] & contained}


def time_to_quality(scene, techniques, size, reference_spp, max_spp=256, frames=3, log=print) -> dict:
    """Each technique's relMSE per region (:func:`quality_masks`) and ms, the reference's own noise floor there
    (caustica.metrics.floor, from two halves of its samples), and Mitsuba's curve on the same machine
    (:func:`mitsuba_curve`: the caustic region timed with only the renders it takes). Mitsuba's needed spp is
    the first whose error reaches the technique's over the pixels the reference can contain (the glints
    apart), and over the caustic region."""
    from ..metrics import relmse
    from ..metrics.floor import FLOOR_MARGIN_DB, noise_floor
    from .compare import reference_halves

    reference, halves = reference_halves(scene, (size, size), reference_spp, progress=None)  # the policy's
    renderer = Renderer((size, size))
    camera = renderer.camera_for(scene)
    rendered = {}
    for name in techniques:
        rendered[name] = timed_render(renderer, scene, name, 1, frames if get_technique(name).uses_gl else 1)
    masks = quality_masks(scene, camera, reference, [image for image, _ in rendered.values()])
    masks = {region: mask for region, mask in masks.items() if mask is None or mask.any()}

    def errors(image) -> dict:
        return {error_key(region): float(relmse(image, reference, mask)) for region, mask in masks.items()}

    floor = {}
    if halves is not None:
        floors = noise_floor(*halves, {r: m for r, m in masks.items() if m is not None})
        floor = {error_key(region): f["relmse"] for region, f in floors.items()}
    techniques_out = {name: {"ms": ms, **errors(image)} for name, (image, ms) in rendered.items()}
    # seed 2: samples independent of the reference's halves (seeds 0 and 1)
    curve = mitsuba_curve(scene, (size, size), errors, masks.get("caustic"), max_spp, seed=2, log=log)
    within = 10.0 ** (FLOOR_MARGIN_DB / 10.0)
    glints = int(masks["glint"].sum()) if "glint" in masks else 0
    for name, entry in techniques_out.items():
        entry["at_reference_floor"] = [key for key, value in floor.items() if key in entry and entry[key] <= within * value]
        log(f"{scene.name:16s} {name:12s} {entry['ms']:.1f} ms; relMSE "
            + ", ".join(f"{region} {entry[error_key(region)]:.5f}" + ("*" if error_key(region) in
                                                                      entry["at_reference_floor"] else "")
                        for region in QUALITY_REGIONS if error_key(region) in entry)
            + f" ({glints} glint pixels)")
        for key, suffix in NEEDED_FROM.items():
            if key not in entry:
                continue
            reached = first_reaching(curve, key, entry[key])
            seconds = reached.get("seconds" + suffix, reached["seconds"]) if reached else None
            entry["mitsuba_spp" + suffix] = reached["spp"] if reached else None
            entry["mitsuba_seconds" + suffix] = seconds
            entry["mitsuba_end_to_end_seconds" + suffix] = \
                reached.get("end_to_end_seconds" + suffix, reached["end_to_end_seconds"]) if reached else None
            entry["speed_ratio" + suffix] = seconds * 1000.0 / entry["ms"] if reached else None
            log(f"{'':16s} {name:12s} {key} {entry[key]:.5f}: "
                + (f"Mitsuba needs {reached['spp']} spp, {timing_label(reached, suffix)}: "
                   f"{speed_text(entry['speed_ratio' + suffix])} than Mitsuba's render"
                   if reached else f"Mitsuba does not reach it within {max_spp} spp"))
    if floor:
        log(f"{'':16s} reference noise floor ({halves[2]}+{halves[3]} spp halves): relMSE "
            + ", ".join(f"{key[:-7] or 'all'} {value:.5f}" for key, value in floor.items())
            + "; * within 3 dB of it (at least half of that error is the reference's own noise)")
    return {"scene": scene.name, "size": size, "reference_spp": reference_spp, "regions": list(masks),
            "region_pixels": {r: int(m.sum()) if m is not None else size * size for r, m in masks.items()},
            "needed_spp_from": "contained_relmse", "reference_floor": floor, "techniques": techniques_out,
            "mitsuba_curve": curve}


def plot(rows: list[dict], quality: list[dict], path) -> None:
    """ms vs resolution per technique, and error vs time with Mitsuba's curve."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = sorted({r["scene"] for r in rows})
    fig, axes = plt.subplots(1, 1 + len(quality), figsize=(5 * (1 + len(quality)), 4), squeeze=False)
    ax = axes[0, 0]
    for scene in scenes:
        for name in sorted({r["technique"] for r in rows}):
            pts = sorted((r["size"], r["ms"]) for r in rows if r["scene"] == scene and r["technique"] == name)
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=f"{scene}: {name}")
    ax.set(xlabel="image side (pixels)", ylabel="ms per frame", yscale="log", title=rows[0]["renderer"] if rows else "")
    ax.legend(fontsize=7)
    for ax, q in zip(axes[0, 1:], quality):
        curve = q["mitsuba_curve"]
        key = q.get("needed_spp_from", "relmse")
        ax.plot([c["seconds"] * 1000 for c in curve], [c[key] for c in curve], marker=".", label="Mitsuba")
        for name, entry in q["techniques"].items():
            ax.scatter([entry["ms"]], [entry[key]], label=name, zorder=3)
        ax.set(xscale="log", yscale="log", xlabel="ms", ylabel=f"{key} vs reference",
               title=f"{q['scene']} {q['size']}^2: error vs time")
        ax.legend(fontsize=7)
    fig.tight_layout()
    try:
        write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    finally:
        plt.close(fig)
