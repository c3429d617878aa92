"""``caustica compare``: every technique against ground truth on one scene, in one run.

For each technique: ms per frame (median of N after a warm-up), PSNR (linear
and sRGB), relMSE, SSIM and FLIP per region (refractor pixels, caustic region,
rest, all), and the angular error of exit directions against ``exact`` where
the technique exposes them. The reference is Mitsuba 3 (cached) when the
``reference`` extra is installed, otherwise the ``exact`` oracle (said so in
the report).

Mitsuba's reference is rendered as two independent halves of its samples, whose
difference gives its own noise floor per region (caustica.metrics.floor): the
best figure any technique can score against it. Figures within 3 dB of it are
flagged: at least half of that error is the reference's noise. ``reference_floor``
(dB) picks the sample count for a floor instead, from a pilot render.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..renderer import Renderer
from ..techniques import get_technique
from .timing import steps, timed_render

REGIONS = ("all", "refractor", "caustic", "rest")
METRICS = ("psnr_linear", "psnr_srgb", "relmse", "ssim", "flip")


@dataclass
class TechniqueResult:
    technique: str
    ms: float
    metrics: dict  # region -> metric -> value
    angular: dict | None  # mean_deg, p95_deg, count, or None where no directions are exposed
    image: np.ndarray = field(repr=False, default=None)
    error_map: np.ndarray = field(repr=False, default=None)
    at_floor: dict = field(default_factory=dict)  # region -> the metrics within 3 dB of the reference's floor

    def to_json(self) -> dict:
        return {"technique": self.technique, "ms_per_frame": self.ms, "regions": _finite(self.metrics),
                "angular_error": _finite(self.angular), "at_reference_floor": self.at_floor}


@dataclass
class CompareResult:
    scene: str
    size: tuple[int, int]
    spp: int
    reference: str
    renderer: str
    region_pixels: dict
    results: list[TechniqueResult]
    reference_image: np.ndarray = field(repr=False, default=None)
    floor: ReferenceFloor | None = None  # None: not measured (the exact fallback, or 1 spp)

    def to_json(self) -> dict:
        return {"scene": self.scene, "size": list(self.size), "spp": self.spp, "reference": self.reference,
                "renderer": self.renderer, "region_pixels": self.region_pixels,
                "reference_floor": None if self.floor is None else self.floor.to_json(),
                "techniques": [r.to_json() for r in self.results]}


@dataclass
class ReferenceFloor:
    """The reference's own noise floor per region (caustica.metrics.floor.noise_floor), from halves of
    ``halves`` samples; ``note``: how its sample count was chosen, when ``--reference-floor`` chose it."""

    spp: int
    halves: tuple[int, int]
    regions: dict
    note: str = ""

    def to_json(self) -> dict:
        return {"spp": self.spp, "halves": list(self.halves), "regions": _finite(self.regions), "note": self.note,
                "how": "PSNR between two independent halves of the reference's samples, plus "
                       "10 log10(N^2 / (n_a n_b)) (+6.02 dB for equal halves); relMSE times n_a n_b / N^2"}

    def whole_srgb(self) -> float:
        """The whole image's sRGB PSNR floor (dB): the figure ``reference_floor`` targets."""
        return self.regions["all"]["psnr_srgb"]


def _finite(value):
    """JSON has no inf/NaN: write them as strings."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def reference_halves(scene, size, spp: int, progress: bool | None = None):
    """(reference, (half_a, half_b, n_a, n_b) or None): Mitsuba's ground truth of ``spp`` samples as two
    independent halves (seeds 0 and 1, each cached), their mean weighted by their counts; 1 spp has no halves."""
    from ..metrics.floor import combine_halves, split_spp
    from ..reference.render import render_reference

    if spp < 2:
        return render_reference(scene, size=size, spp=spp, progress=progress), None
    n_a, n_b = split_spp(spp)
    half_a = render_reference(scene, size=size, spp=n_a, progress=progress, seed=0)
    half_b = render_reference(scene, size=size, spp=n_b, progress=progress, seed=1)
    return combine_halves(half_a, half_b, n_a, n_b), (half_a, half_b, n_a, n_b)


def reference_image(scene, size, reference_spp: int, progress: bool | None = None):
    """(image, description, halves): Mitsuba when installed (halves as :func:`reference_halves`), else the
    exact oracle at the same spp (halves None: its samples are a fixed grid, so it has no independent halves)."""
    from ..errors import CausticaError

    try:
        from ..reference.render import reference_caveats

        image, halves = reference_halves(scene, size, reference_spp, progress)
        caveats = "".join(f"; {c}" for c in reference_caveats(scene))
        return image, f"mitsuba ({reference_spp} spp, composite of path and ptracer{caveats})", halves
    except ImportError:
        pass
    except CausticaError as exc:  # the reference extra is missing
        warnings.warn(f"{exc}; comparing against 'exact' instead", stacklevel=2)
    image = Renderer(size).render(scene, "exact", spp=reference_spp)
    return image, (f"exact ({reference_spp} spp, caustics from exact photons; Mitsuba not available: no caustics "
                   "from the environment in the reference)"), None


PILOT_SPP = 32  # the pilot reference of --reference-floor: two halves of 16
MAX_FLOOR_SPP = 4096  # the most samples --reference-floor renders, whatever floor it is asked for
FLOOR_ROUNDS = 3  # renders after the pilot, at most: each measures its floor and corrects the count
FLOOR_TOLERANCE_DB = 0.25  # a render whose floor is this close below the target is kept


def spp_for_reference_floor(scene, size, target_db: float, progress: bool | None = None,
                            cap: int = MAX_FLOOR_SPP) -> tuple[int, str]:
    """(spp, note): the reference's sample count for a whole-image sRGB PSNR floor of ``target_db``, at most
    ``cap``. A PILOT_SPP pilot predicts the count (caustica.metrics.floor.spp_for_floor: noise variance ~ 1/spp);
    each render at a predicted count (its halves are cached, so compare reads them again) measures its own floor
    and, where it falls more than FLOOR_TOLERANCE_DB short, predicts again from itself with the growth it saw
    (metrics.floor.measured_slope), up to FLOOR_ROUNDS times: a few samples miss the rare bright paths
    (fireflies) and underestimate the noise. ``note`` gives each step
    and, where the cap was hit, what the capped count gives and what to do."""
    from ..errors import ReferenceUnavailableError
    from ..metrics.floor import measured_slope, noise_floor, spp_for_floor

    def measured(spp: int) -> float:
        try:
            _, halves = reference_halves(scene, size, spp, progress)
        except ReferenceUnavailableError as exc:
            raise ReferenceUnavailableError(f"--reference-floor measures Mitsuba's noise: {exc}") from None
        return noise_floor(*halves)["all"]["psnr_srgb"]

    spp, floor_db = PILOT_SPP, measured(PILOT_SPP)
    steps_taken, slope = [f"{spp} spp pilot: {floor_db:.2f} dB"], 1.0
    for _ in range(FLOOR_ROUNDS):
        if floor_db >= target_db - FLOOR_TOLERANCE_DB and spp > PILOT_SPP:
            break
        needed = spp_for_floor(spp, floor_db, target_db, slope)
        if needed > cap:
            capped = cap - cap % 2
            reached = floor_db + 10.0 * math.log10(capped / spp)
            return capped, (f"a {target_db:g} dB floor needs about {needed} spp ({'; '.join(steps_taken)}), more "
                            f"than the cap of {cap}: rendering {capped} spp for about {reached:.1f} dB; ask for a "
                            "lower --reference-floor or a smaller --size")
        if needed <= spp:
            break
        previous, previous_db = spp, floor_db
        spp, floor_db = needed, measured(needed)
        slope = measured_slope(previous, previous_db, spp, floor_db)  # the next prediction follows what was seen
        steps_taken.append(f"{spp} spp: {floor_db:.2f} dB")
    return spp, f"{spp} spp for a {target_db:g} dB floor ({'; '.join(steps_taken)})"


def compare(scene, techniques: list[str], size=None, spp: int = 4, frames: int = 5, reference_spp: int = 256,
            progress: bool | None = None, log=print, reference_floor: float | None = None) -> CompareResult:
    """Render each technique and the reference; measure them per region. ``progress``: the reference's
    progress display (caustica.progress: None follows the policy, True always, False never).
    ``reference_floor`` (dB): pick the reference's spp for that whole-image sRGB PSNR floor instead of
    ``reference_spp`` (:func:`spp_for_reference_floor`)."""
    from ..metrics import angular_error, compare_images, exact_exit_directions, flip_map, region_masks
    from ..metrics.floor import at_floor, noise_floor

    for name in techniques:
        get_technique(name)  # fail early on an unknown name
    renderer = Renderer(size)
    camera = renderer.camera_for(scene)
    note = ""
    if reference_floor is not None:
        log(f"pilot reference for {scene.name} at {camera.size[0]}x{camera.size[1]} ({PILOT_SPP} spp) ...")
        reference_spp, note = spp_for_reference_floor(scene, camera.size, reference_floor, progress)
        log(f"reference floor: {note}")
    log(f"reference for {scene.name} at {camera.size[0]}x{camera.size[1]} ...")
    reference, description, halves = reference_image(scene, camera.size, reference_spp, progress)
    masks = region_masks(scene, camera, spp=max(1, spp))
    floor = None
    if halves is not None:
        half_a, half_b, n_a, n_b = halves
        floor = ReferenceFloor(reference_spp, (n_a, n_b), noise_floor(half_a, half_b, n_a, n_b, masks), note)
    exact_dirs = None
    results = []
    with steps(len(techniques), f"compare {scene.name}", "techniques") as bar:
        for name in techniques:
            log(f"rendering {name} ...")
            bar.set_postfix_str(name)
            image, ms = timed_render(renderer, scene, name, spp, frames)
            metrics = compare_images(image, reference, masks)
            angular = None
            if get_technique(name).uses_gl:
                directions = renderer.exit_directions(scene, name)
                if directions is not None:
                    if exact_dirs is None:
                        exact_dirs = exact_exit_directions(scene, camera)
                    dirs, valid = directions
                    angular = angular_error(dirs, exact_dirs[0], valid & exact_dirs[1])
            elif name == "exact":
                angular = {"mean_deg": 0.0, "p95_deg": 0.0, "count": int(masks["refractor"].sum())}
            flags = {} if floor is None else {region: at_floor(metrics[region], floor.regions[region])
                                              for region in metrics}
            results.append(TechniqueResult(name, ms, metrics, angular, image, flip_map(image, reference), flags))
            bar.update()
    gl = renderer.info()["renderer"] if renderer._device is not None else "none (CPU techniques only)"
    return CompareResult(scene.name, camera.size, spp, description, gl,
                         {k: int(v.sum()) for k, v in masks.items()}, results, reference, floor)


TABLE_HEADER = ("technique", "ms", "PSNR lin", "PSNR sRGB", "relMSE", "SSIM", "FLIP", "angle mean/p95 (deg)")


FLOOR_MARK = "*"


def table_cells(r: TechniqueResult, region: str) -> list[str]:
    """One technique's row of the report in ``region``, as the cells under TABLE_HEADER; a figure within
    3 dB of the reference's noise floor there ends in FLOOR_MARK."""
    m = r.metrics[region]
    flagged = r.at_floor.get(region, ())

    def cell(key: str, text: str) -> str:
        return text + FLOOR_MARK if key in flagged else text

    angle = "-" if r.angular is None else f"{r.angular['mean_deg']:.3f}/{r.angular['p95_deg']:.3f}"
    return [r.technique, f"{r.ms:.1f}", cell("psnr_linear", f"{m['psnr_linear']:.2f}"),
            cell("psnr_srgb", f"{m['psnr_srgb']:.2f}"), cell("relmse", f"{m['relmse']:.5f}"),
            f"{m['ssim']:.3f}", f"{m['flip']:.3f}", angle]


def floor_cells(floor: ReferenceFloor, region: str) -> list[str]:
    """The reference's noise floor in ``region`` as a row under TABLE_HEADER."""
    f = floor.regions[region]
    return ["(reference floor)", "-", f"{f['psnr_linear']:.2f}", f"{f['psnr_srgb']:.2f}", f"{f['relmse']:.5f}",
            "-", "-", "-"]


def floor_summary(floor: ReferenceFloor | None) -> str:
    """One line on the reference's noise floor for the report's head, or why there is none."""
    if floor is None:
        return "reference noise floor: not measured (needs the Mitsuba reference at 2 spp or more)"
    return (f"reference noise floor (from two independent halves of its {floor.halves[0]}+{floor.halves[1]} spp): "
            f"{floor.whole_srgb():.2f} dB sRGB over the whole image; {FLOOR_MARK}: a figure within 3 dB of it, "
            "at least half of whose error is the reference's own noise")


def column_widths(rows: list[list[str]]) -> list[int]:
    """The widest cell of each column."""
    return [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]


def aligned(rows: list[list[str]], widths: list[int] | None = None) -> list[str]:
    """Rows of cells as lines, each column ``widths`` wide (default: its widest cell here): the first
    left-aligned, the others right-aligned, two spaces apart, so a column starts at the same place on every line."""
    widths = widths or column_widths(rows)
    return ["  ".join(cell.ljust(w) if i == 0 else cell.rjust(w) for i, (cell, w) in enumerate(zip(row, widths)))
            for row in rows]


def format_table(result: CompareResult) -> str:
    """The report: one block per region, one row per technique and the reference's noise floor; the columns
    as wide as their content in every block, so long technique names keep them aligned."""
    blocks = {region: [list(TABLE_HEADER), *(table_cells(r, region) for r in result.results),
                       *([floor_cells(result.floor, region)] if result.floor is not None else [])]
              for region in REGIONS}
    widths = column_widths([row for block in blocks.values() for row in block])
    lines = [f"scene {result.scene}, {result.size[0]}x{result.size[1]}, {result.spp} spp; "
             f"reference: {result.reference}; GL: {result.renderer}", floor_summary(result.floor)]
    if result.floor is not None and result.floor.note:
        lines.append(f"reference samples: {result.floor.note}")
    for region, block in blocks.items():
        pixels = result.region_pixels.get(region, sum(result.region_pixels.values()))
        lines += [f"\n[{region}] ({pixels} pixels)", *aligned(block, widths)]
    return "\n".join(lines)
