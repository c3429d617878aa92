"""``caustica bench``: speed of every technique, and its time-to-quality against Mitsuba.

Per scene, size and technique: the median ms per frame, per-pass ms (GPU timer
queries on a GPU, finish() and wall clock on llvmpipe), triangle count, and
the ratio to a ``plain`` diffuse frame of the same scene in the same run.
Time to quality: each technique's relMSE against the high-sample reference
(whole image, and the caustic region where the scene has one), then Mitsuba
at 1, 2, 4, ... spp timed on the same machine; the spp and seconds Mitsuba
needs to match the technique's error give the speed ratio.
"""
from __future__ import annotations

import time

import numpy as np

from ..atomic import write_atomic
from ..renderer import Renderer
from ..techniques import get_technique
from .timing import steps, timed_render


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
    """Mitsuba's error against time on this machine, one point per spp in 1, 2, 4, ... ``max_spp``: ``seconds``
    of ``mi.render`` on the composite's scenes loaded once and warmed; ``seconds_caustic`` (when ``caustic``,
    an (H, W) mask, is given), only the renders whose weight reaches those pixels (reference/render.py
    LoadedReference: the light tracer and the environment's path, not the lights' path, on purely diffuse
    pixels); ``end_to_end_seconds``, an uncached ``render_reference`` (export, load and every render); and
    ``errors(image)``, a dict. ``seed``: pick one the reference did not use, so its error is not
    underestimated. ``size`` is (width, height); ``repeats``: LoadedReference.render's (the fastest of
    that many calls)."""
    from ..reference.render import LoadedReference, render_reference

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
            start = time.perf_counter()
            render_reference(scene, size=size, spp=spp, cache=False, progress=False, seed=seed)
            point = {"spp": spp, "seconds": sum(seconds.values()), "end_to_end_seconds": time.perf_counter() - start,
                     **errors(image)}
            if caustic_renders:
                point["seconds_caustic"] = sum(seconds[key] for key in caustic_renders)
            curve.append(point)
            bar.update()
            log(f"  mitsuba {spp:4d} spp: render {point['seconds']:7.2f} s (end to end "
                f"{point['end_to_end_seconds']:.2f} s), "
                + ", ".join(f"{k} {v:.5f}" for k, v in point.items() if "relmse" in k))
    return curve


def first_reaching(curve: list[dict], key: str, error: float) -> dict | None:
    """The first point of a :func:`mitsuba_curve` whose ``key`` error is at most ``error``; None if none is."""
    return next((c for c in curve if c[key] <= error), None)


def time_to_quality(scene, techniques, size, reference_spp, max_spp=256, frames=3, log=print) -> dict:
    """Each technique's relMSE and ms, and Mitsuba's curve on the same machine (:func:`mitsuba_curve`: the
    caustic region, when the scene has one, timed with only the renders it takes)."""
    from ..metrics import caustic_region, relmse
    from ..reference.render import render_reference

    reference = render_reference(scene, size=(size, size), spp=reference_spp, progress=None)  # the policy's
    renderer = Renderer((size, size))
    techniques_out = {}
    caustic = caustic_region(scene, renderer.camera_for(scene))
    regions = {"relmse": None, "caustic_relmse": caustic} if caustic.any() else {"relmse": None}

    def errors(image) -> dict:
        return {key: float(relmse(image, reference, mask)) for key, mask in regions.items()}

    for name in techniques:
        image, ms = timed_render(renderer, scene, name, 1, frames if get_technique(name).uses_gl else 1)
        techniques_out[name] = {"ms": ms, **errors(image)}
    # seed 1: samples independent of the reference's (seed 0)
    curve = mitsuba_curve(scene, (size, size), errors, caustic, max_spp, seed=1, log=log)
    for name, entry in techniques_out.items():
        for key in regions:  # whole image, and the caustic region where the scene has one
            suffix = "" if key == "relmse" else "_caustic"
            reached = first_reaching(curve, key, entry[key])
            seconds = reached.get("seconds" + suffix, reached["seconds"]) if reached else None
            entry["mitsuba_spp" + suffix] = reached["spp"] if reached else None
            entry["mitsuba_seconds" + suffix] = seconds
            entry["mitsuba_end_to_end_seconds" + suffix] = reached["end_to_end_seconds"] if reached else None
            entry["speed_ratio" + suffix] = seconds * 1000.0 / entry["ms"] if reached else None
            log(f"{scene.name:16s} {name:12s} {key} {entry[key]:.5f} in {entry['ms']:.1f} ms; "
                + (f"Mitsuba needs {reached['spp']} spp, render {seconds:.2f} s (end to end "
                   f"{reached['end_to_end_seconds']:.2f} s): x{entry['speed_ratio' + suffix]:.0f} faster"
                   if reached else f"Mitsuba does not reach it within {max_spp} spp"))
    return {"scene": scene.name, "size": size, "reference_spp": reference_spp, "techniques": techniques_out,
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
        ax.plot([c["seconds"] * 1000 for c in curve], [c["relmse"] for c in curve], marker=".", label="Mitsuba")
        for name, entry in q["techniques"].items():
            ax.scatter([entry["ms"]], [entry["relmse"]], label=name, zorder=3)
        ax.set(xscale="log", yscale="log", xlabel="ms", ylabel="relMSE vs reference",
               title=f"{q['scene']} {q['size']}^2: error vs time")
        ax.legend(fontsize=7)
    fig.tight_layout()
    try:
        write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    finally:
        plt.close(fig)
