"""A batch job (what to render, as data) and its run: the frame loop, the manifest and resuming.

A job's key hashes everything its images depend on (the scene's content, the sweep, the frame
count, size, spp, antialias, technique, labels and file names), not how it runs (workers, Ray): a run
with the same key resumes the folder, another is refused there unless ``force``.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..atomic import Terminated, missing_folders
from ..errors import CausticaError, OutputError, short
from .manifest import JOB_FILE, LOCK_FILE, MANIFEST, Manifest
from .sweep import DEFAULT_OUTPUT, IMAGE_FORMATS, LABEL_FORMATS, MAX_FRAMES, Variation, check_output, check_seed


@dataclass(frozen=True)
class Job:
    """Everything a worker needs to render any frame of the job (picklable: it travels to spawned
    processes and Ray tasks). ``scene`` is a preset name, a scene file's absolute path or a Scene."""

    scene: object
    out_dir: str
    frames: int
    seed: int = 0
    size: tuple | None = None
    spp: int = 1
    antialias: str = "none"  # passes/resolve.ANTIALIAS_MODES
    technique: str = "auto"
    labels: tuple = ()
    labels_format: str = "exr"
    image_format: str = "png"
    output: str = DEFAULT_OUTPUT
    variations: tuple = ()
    base_dir: str = "."
    environment: str | None = None
    camera: str | None = None

    def base_scene(self):
        """The scene every frame starts from: the job's, with its ``environment`` in place."""
        from ..scene.environment import environment_option
        from ..scene.io import load_scene
        from ..scene.scene import Scene

        scene = dataclasses.replace(self.scene) if isinstance(self.scene, Scene) else load_scene(self.scene, self.camera)
        if self.environment is not None:
            scene.environment = environment_option(self.environment)
        return scene

    def values(self, index: int) -> dict:
        """Frame ``index``'s value of every varied key."""
        return {v.key: v.value(self.seed, index, self.frames) for v in self.variations}

    def files(self, index: int) -> dict[str, str]:
        """The files of frame ``index``, relative to the output folder, by role."""
        from ..labels import labels_file

        stem = self.output.format(index=index)
        files = {"image": f"{stem}.{self.image_format}"}
        if self.labels:
            files["labels"] = labels_file(stem, self.labels_format)
        return files

    def description(self, scene) -> dict:
        """The job as JSON data, the scene by its content hash."""
        from ..reference.render import cache_key

        camera = scene.camera if self.size is None else scene.camera.with_size(*self.size)
        description = {"scene": cache_key(scene, camera, self.spp, 0, "batch", False), "frames": self.frames,
                       "seed": self.seed, "spp": self.spp, "technique": self.technique, "labels": list(self.labels),
                       "labels_format": self.labels_format, "image_format": self.image_format,
                       "output": self.output, "variations": [[v.key, v.mode, list(v.values)] for v in self.variations]}
        if self.antialias != "none":  # left out when off: folders of jobs from before the option keep their key
            description["antialias"] = self.antialias
        return description


def job_key(description: dict) -> str:
    return hashlib.sha1(json.dumps(description, sort_keys=True).encode()).hexdigest()[:20]


def make_job(scene_or_sweep, out_dir, *, frames=None, orbit=None, size=None, spp=None, antialias=None,
             technique=None, labels=None, labels_format=None, image_format=None, seed=None, environment=None,
             camera=None):
    """The Job for a scene (preset, scene file, glTF, Scene) or a sweep file, and its base scene, checked
    up front: SceneError, TechniqueError or OutputError in one line. Arguments given win over the sweep's."""
    from ..passes.post.resolve import check_antialias
    from ..scene.scene import Scene
    from .edits import SceneEditor
    from .sweep import Sweep, is_sweep_file, read_sweep

    source = scene_or_sweep
    sweep = read_sweep(source) if isinstance(source, (str, Path)) and is_sweep_file(source) else \
        source if isinstance(source, Sweep) else None
    settings = dict(sweep.settings) if sweep else {}
    given = {"frames": frames, "size": size, "spp": spp, "antialias": antialias, "technique": technique,
             "labels": labels, "labels_format": labels_format, "image_format": image_format, "seed": seed}
    settings.update({k: v for k, v in given.items() if v is not None})
    variations = list(sweep.variations) if sweep else []
    if orbit is not None:
        variations = [v for v in variations if v.key != "camera.orbit"] + [_orbit(orbit)]
    scene = sweep.scene if sweep else source
    if isinstance(scene, (str, Path)) and Path(scene).suffix:
        scene = str(Path(scene).resolve())
    elif not isinstance(scene, (str, Scene)):
        raise CausticaError(f"batch takes a preset name, a scene or sweep file, or a Scene, not {short(scene)}")
    if environment is not None and Path(environment).suffix:
        environment = str(Path(environment).resolve())
    job = Job(scene=scene, out_dir=str(Path(out_dir).resolve()), frames=_frames(settings.get("frames", 1)),
              seed=check_seed(settings.get("seed", 0)), size=_size(settings.get("size")),
              spp=int(settings.get("spp", 1)),
              antialias=check_antialias(settings.get("antialias", "none")),
              technique=settings.get("technique", "auto"), labels=_labels(settings.get("labels", ())),
              labels_format=_choice(settings.get("labels_format", "exr"), LABEL_FORMATS, "labels format"),
              image_format=_choice(settings.get("image_format", "png"), IMAGE_FORMATS, "image format"),
              output=check_output(settings.get("output", DEFAULT_OUTPUT)), variations=tuple(variations),
              base_dir=str(Path(sweep.base_dir).resolve()) if sweep else ".", environment=environment, camera=camera)
    _check_technique(job)
    base = job.base_scene()
    editor = SceneEditor(base, job.base_dir)
    for variation in job.variations:
        editor.check(variation)
    return job, base


def _orbit(degrees) -> Variation:
    from ..scene import rules

    return Variation("camera.orbit", "number", "orbit", (rules.number(degrees, "orbit", -1e6, 1e6, hint=" degrees"),))


def _frames(frames) -> int:
    if isinstance(frames, bool) or not isinstance(frames, int) or not 1 <= frames <= MAX_FRAMES:
        raise CausticaError(f"frames must be an integer in [1, {MAX_FRAMES}] (got {short(frames)}); "
                            "give a positive count")
    return frames


def _size(size):
    from ..errors import RenderOptionError
    from ..scene import rules

    return None if size is None else rules.image_size(size, "size", error=RenderOptionError)


def _choice(value, choices, what: str) -> str:
    from ..errors import closest_name

    if value not in choices:
        raise OutputError(f"{what} {short(value)} is unknown{closest_name(str(value), choices)}; "
                          f"choose one of {', '.join(choices)}")
    return value


def _labels(names) -> tuple:
    """The label layers asked for (caustica.labels' names, in its order)."""
    from ..labels import check_labels

    return check_labels(names) if names else ()


def _check_technique(job: Job) -> None:
    from .. import frame_limits
    from ..techniques import get_technique
    from ..techniques.base import check_spp

    frame_limits.check_spp(job.spp)
    check_spp(get_technique(job.technique), job.spp)


@dataclass
class Progress:
    """Where a run stands, passed to the ``progress`` callback after each frame (``row``)."""

    total: int
    done: int = 0  # frames finished, earlier runs' included
    failed: int = 0  # frames that failed in this run
    skipped: int = 0  # frames finished by earlier runs
    rendered: int = 0  # frames rendered by this run, failed ones included
    started: float = field(default_factory=time.perf_counter)
    row: dict | None = None

    @property
    def elapsed_s(self) -> float:
        return time.perf_counter() - self.started

    @property
    def rate(self) -> float:
        """Frames per second of this run."""
        return self.rendered / self.elapsed_s if self.rendered else 0.0

    @property
    def eta_s(self) -> float | None:
        left = self.total - self.done - self.failed
        return left / self.rate if self.rate else None


def run_job(job: Job, base=None, *, workers: int = 1, ray: str | None = None, devices=None, force: bool = False,
            progress=None) -> list[dict]:
    """Render the job's unfinished frames into ``job.out_dir`` (``workers``, ``ray``, ``devices``: as
    workers.render_frames) and return every frame's manifest row, sorted. ``progress(Progress)`` is called
    after each frame (an exception from it stops the run, the finished frames kept). A run that ends in an
    error before its first frame (a refused folder, an unreachable cluster) leaves nothing it made behind; an
    interrupted one (Ctrl-C, SIGTERM) re-raises with how many frames the folder keeps."""
    out = Path(job.out_dir)
    if out.exists() and not out.is_dir():
        raise OutputError(f"output folder {out} is a file; give a folder name")
    description = job.description(job.base_scene() if base is None else base)
    made = missing_folders(out / JOB_FILE)[::-1]  # out and its missing parents, deepest first
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        _remove_new(out, made, None)
        raise OutputError(f"cannot create the output folder {out} ({exc.strerror}); check the path") from None
    records = {name for name in (JOB_FILE, MANIFEST, LOCK_FILE) if (out / name).exists()}
    manifest = Manifest(out)
    state = Progress(total=job.frames)
    try:
        manifest.lock()
        rows = manifest.claim(job_key(description), description, force)
        return _run(job, manifest, rows, state, workers, ray, devices, progress)
    except (KeyboardInterrupt, Terminated) as stop:
        stop.args = (f"{str(stop) or 'interrupted'}: {_kept(state, out)}",)
        _remove_new(out, made, records if manifest.locked else None, state)
        raise
    except BaseException:
        _remove_new(out, made, records if manifest.locked else None, state)
        raise
    finally:
        manifest.unlock()


def _kept(state: Progress, out: Path) -> str:
    """What an interrupted run leaves: the frames kept and how to render the others."""
    left = state.total - state.done
    return (f"kept {state.done} of {state.total} frames in {out} (manifest.jsonl)"
            + (f"; run the same command again to render the other {left}" if left else ""))


def _remove_new(out: Path, made: list[Path], records: set | None, state: Progress | None = None) -> None:
    """After a run that rendered no frame: remove the folder's records that were not there before it
    (``records``: those that were; None: the run never held the folder, and its records are another
    run's) and the folders it made (``made``), when empty."""
    if state is not None and state.rendered:
        return
    if records is None:
        records = {JOB_FILE, MANIFEST, LOCK_FILE}
    if JOB_FILE not in records:  # a fresh folder: this run wrote its job.json and manifest
        for name in (JOB_FILE, MANIFEST):
            (out / name).unlink(missing_ok=True)
    if LOCK_FILE not in records:
        (out / LOCK_FILE).unlink(missing_ok=True)  # while still locked: no other run holds this file
    for folder in made:
        try:
            folder.rmdir()
        except OSError:
            break


def _run(job: Job, manifest: Manifest, rows: dict, state: Progress, workers: int, ray, devices,
         progress) -> list[dict]:
    from .workers import render_frames

    out = manifest.dir
    finished = {i for i, row in rows.items() if i < job.frames and manifest.finished(row)}
    state.done = state.skipped = len(finished)
    pending = [i for i in range(job.frames) if i not in finished]
    try:
        with manifest:
            for row in render_frames(job, pending, workers=workers, ray=ray, devices=devices):
                if "error" not in row and not manifest.present(row):
                    row = {**row, "error": f"its files are not in {out} as written (on a cluster the output "
                                           "folder must be on a file system every node shares)"}
                manifest.append(row)
                rows[row["index"]] = row
                state.rendered += 1
                state.failed += "error" in row
                state.done += "error" not in row
                state.row = row
                if progress is not None:
                    progress(state)
    finally:
        manifest.compact(rows)
    return [rows[i] for i in sorted(rows)]
