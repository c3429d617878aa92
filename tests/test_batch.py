"""caustica batch: orbits and sweeps, workers, resume, refusal, failed frames, bad sweep files, Ray, labels."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import caustica
from caustica.cli import main

SIZE = (48, 36)
FAST = dict(size=SIZE, spp=1, technique="plain")


def rows_of(folder: Path) -> list[dict]:
    return [json.loads(line) for line in (folder / "manifest.jsonl").read_text().splitlines()]


def pixels(folder: Path, row: dict) -> np.ndarray:
    return np.asarray(Image.open(folder / row["files"]["image"]))


def write_sweep(folder: Path, text: str) -> Path:
    path = folder / "sweep.toml"
    path.write_text(text)
    return path


def run_cli(args: list[str], capsys) -> tuple[int, str]:
    code = main(args)
    return code, capsys.readouterr().err


def test_orbit_with_two_workers_matches_one_worker(tmp_path):
    one = caustica.batch("caustic-sphere", tmp_path / "one", 12, orbit=360, **FAST)
    two = caustica.batch("caustic-sphere", tmp_path / "two", 12, orbit=360, workers=2, **FAST)
    assert [r["index"] for r in two] == list(range(12)) and len(rows_of(tmp_path / "two")) == 12
    assert sorted(p.name for p in (tmp_path / "two").glob("frame_*.png")) == [f"frame_{i:06d}.png" for i in range(12)]
    assert [r["values"]["camera.orbit"] for r in two] == pytest.approx([30.0 * i for i in range(12)])
    assert {r["worker"] for r in one} == {os.getpid()}
    assert os.getpid() not in {r["worker"] for r in two} and len({r["worker"] for r in two}) <= 2
    for a, b in zip(one, two):  # a frame is the same whichever process renders it
        assert np.array_equal(pixels(tmp_path / "one", a), pixels(tmp_path / "two", b))
    assert not np.array_equal(pixels(tmp_path / "one", one[0]), pixels(tmp_path / "one", one[3]))
    assert all(r["renderer"] and r["technique"] == "plain" and r["seed"] == 0 and r["ms"] > 0 for r in two)
    from caustica.batch.devices import ENV, placement

    assert {r["device"] for r in one} == {int(os.environ.get(ENV, 0))}  # this process's device
    assert {r["device"] for r in two} == set(placement()[:2])  # the machine's GPUs, llvmpipe without one


@pytest.mark.parametrize("technique", ["env-map+photon-splats", "auto"])
def test_splatted_caustics_are_the_same_in_every_worker(tmp_path, technique):
    # Integer atomics: a caustic frame is bit-identical in a spawned worker and in this process.
    kwargs = dict(size=SIZE, technique=technique, orbit=40)
    one = caustica.batch("caustic-sphere", tmp_path / "one", 4, **kwargs)
    two = caustica.batch("caustic-sphere", tmp_path / "two", 4, workers=2, **kwargs)
    assert all("error" not in r for r in one + two) and one[0]["technique"] == two[0]["technique"]
    # Each worker's first frame, and only that one, is marked as the warm-up (its ms holds the shaders' compile).
    assert [r["warmup"] for r in one] == [True, False, False, False]
    firsts = {}
    for r in sorted(two, key=lambda r: r["time"]):
        firsts.setdefault(r["worker"], r["index"])
    assert {r["index"] for r in two if r["warmup"]} == set(firsts.values())
    for a, b in zip(one, two):
        assert np.array_equal(pixels(tmp_path / "one", a), pixels(tmp_path / "two", b))


def test_orbit_turns_counter_clockwise_seen_from_above(tmp_path):
    from caustica.batch.job import make_job
    from caustica.batch.edits import SceneEditor

    job, base = make_job("glass-sphere", tmp_path, frames=4, orbit=360)  # camera at +Z, look_at the origin
    editor = SceneEditor(base)
    positions = [editor.apply(job.values(i)).camera.position for i in range(4)]
    assert np.allclose(positions, [[0, 0, 4], [4, 0, 0], [0, 0, -4], [-4, 0, 0]], atol=1e-9)


def test_interrupted_run_resumes_without_rendering_finished_frames(tmp_path):
    out = tmp_path / "out"

    def stop_after_three(state):
        if state.rendered == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        caustica.batch("caustic-sphere", out, 8, orbit=90, progress=stop_after_three, **FAST)
    first = {r["index"]: r for r in rows_of(out)}
    assert sorted(first) == [0, 1, 2]
    seen = []
    rows = caustica.batch("caustic-sphere", out, 8, orbit=90, progress=lambda s: seen.append(s.row["index"]), **FAST)
    assert sorted(seen) == [3, 4, 5, 6, 7]  # only the unfinished frames rendered
    assert [r["index"] for r in rows] == list(range(8)) and [r["index"] for r in rows_of(out)] == list(range(8))
    assert all(rows[i]["time"] == first[i]["time"] for i in range(3))
    # A damaged file is not finished: that frame alone renders again.
    (out / rows[5]["files"]["image"]).write_bytes(b"\x89PNG broken")
    seen.clear()
    caustica.batch("caustic-sphere", out, 8, orbit=90, progress=lambda s: seen.append(s.row["index"]), **FAST)
    assert seen == [5]


def test_killed_run_restarts_and_ends_with_every_frame_once(tmp_path):
    out = tmp_path / "out"
    command = [sys.executable, "-m", "caustica.cli", "batch", "caustic-sphere", "-o", str(out), "--frames", "16",
               "--orbit", "180", "--size", "48x36", "-t", "env-map", "--workers", "2"]
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        manifest = out / "manifest.jsonl"
        if manifest.exists() and manifest.read_text().count("\n") >= 3:
            break
        time.sleep(0.02)
    child.send_signal(signal.SIGKILL)
    child.wait()
    before = {json.loads(line)["index"]: json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines()
              if line.endswith("}")}
    assert 3 <= len(before) < 16
    time.sleep(0.3)  # the orphaned workers notice their parent is gone
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    rows = rows_of(out)
    assert [r["index"] for r in rows] == list(range(16))
    for index, row in before.items():
        if "error" not in row:
            assert rows[index]["time"] == row["time"]  # not rendered again
    assert "frame 16/16" in done.stderr  # plain progress lines when stderr is no terminal


def test_a_worker_killed_mid_run_costs_at_most_its_frame(tmp_path):
    killed = []

    def kill_one(state):
        if not killed:
            killed.append(state.row["worker"])
            os.kill(killed[0], signal.SIGKILL)

    rows = caustica.batch("caustic-sphere", tmp_path, 12, orbit=360, workers=2, progress=kill_one, **FAST)
    assert [r["index"] for r in rows] == list(range(12))
    failed = [r for r in rows if "error" in r]
    assert len(failed) <= 1 and all("worker process died" in r["error"] for r in failed)
    assert killed[0] not in {r["worker"] for r in rows if r["time"] > rows[0]["time"] + 5}
    again = caustica.batch("caustic-sphere", tmp_path, 12, orbit=360, **FAST)
    assert all("error" not in r for r in again)


def test_sweep_values_land_in_manifest_and_images(tmp_path):
    sweep = write_sweep(tmp_path, """
scene = "glass-sphere"
frames = 4
seed = 3
technique = "env-map"
size = [48, 36]
[objects.sphere]
ior = { uniform = [1.1, 1.9] }
[environment]
strength = { list = [1.0], cycle = true }
""")
    rows = caustica.batch(sweep, tmp_path / "out")
    iors = [r["values"]["objects.sphere.ior"] for r in rows]
    assert all(1.1 <= v <= 1.9 for v in iors) and len(set(iors)) == 4
    assert all(r["values"]["environment.strength"] == 1.0 for r in rows)
    # Frame i's draw depends on (seed, i, key) only: a longer job draws the same values first.
    longer = caustica.batch(sweep, tmp_path / "longer", 6)  # an argument wins over the sweep's frames = 4
    assert len(longer) == 6
    assert [r["values"]["objects.sphere.ior"] for r in longer[:4]] == iors
    images = [pixels(tmp_path / "out", r).astype(int) for r in rows]
    centre, corner = (slice(14, 22), slice(20, 28)), (slice(0, 3), slice(0, 3))
    assert np.abs(images[0][centre] - images[1][centre]).max() > 20  # the glass changed
    assert all(np.array_equal(images[0][corner], im[corner]) for im in images)  # the background did not


def test_every_sweep_key_edits_the_scene_as_documented(tmp_path):
    from caustica.batch.job import make_job
    from caustica.batch.edits import SceneEditor
    from caustica.batch.sweep import path_point

    sweep = write_sweep(tmp_path, """
scene = "caustic-sphere"
frames = 3
technique = "plain"
size = [48, 36]
[camera]
path = [[0, 2, 4], [4, 2, 4], [4, 2, 0]]
fov_y = { list = [30, 50], cycle = true }
[objects.ball]
position = { uniform = [[-0.2, 0.5, -0.2], [0.2, 0.5, 0.2]] }
rotation = [0, 45, 0]
scale = { uniform = [0.5, 1.5] }
material = { list = [{ type = "glass", ior = 1.3 }, { type = "mirror" }], cycle = true }
[objects.floor]
color = { uniform = [0.2, 0.9] }
[environment]
image = { list = ["white", "sky-checker"], cycle = true }
rotation = { uniform = [0, 360] }
strength = 2
[lights.0]
position = [1, 3, 1]
intensity = { uniform = [[5, 5, 5], [10, 20, 30]] }
""")
    job, base = make_job(sweep, tmp_path / "out")
    editor = SceneEditor(base)
    scenes = [editor.apply(job.values(i)) for i in range(3)]
    assert [list(s.camera.position) for s in scenes] == [[0, 2, 4], [4, 2, 4], [4, 2, 0]]  # the path's ends, middle
    assert [s.camera.fov_y for s in scenes] == [30, 50, 30]
    ball = [s.objects[0] for s in scenes]
    assert [b.material.kind for b in ball] == ["glass", "mirror", "glass"] and ball[0].material.ior == 1.3
    assert all(np.all(np.abs(b.transform.position - [0, 0.5, 0]) <= [0.2, 0, 0.2]) for b in ball)
    assert all(list(b.transform.rotation) == [0, 45, 0] and b.transform.scale[0] == b.transform.scale[2] for b in ball)
    grey = scenes[0].objects[1].material.color
    assert grey[0] == grey[1] == grey[2] and 0.2 <= grey[0] <= 0.9  # number ends: one draw for every channel
    assert [s.environment.source for s in scenes] == ["procedural:white", "procedural:sky-checker", "procedural:white"]
    assert all(s.environment.strength == 2 and 0 <= s.environment.rotation <= 360 for s in scenes)
    light = scenes[1].lights[0]
    assert list(light.position) == [1, 3, 1] and 5 <= light.intensity[0] <= 10 and 5 <= light.intensity[2] <= 30
    assert base.objects[0].material.ior == 1.5 and list(base.camera.position) == [0, 2.2, 4.2]  # base untouched
    # distance and elevation about look_at, then the turn: glass-sphere's camera is at +Z 4 from the origin.
    job, base = make_job("glass-sphere", tmp_path / "b")
    camera = SceneEditor(base).apply({"camera.distance": 5.0, "camera.elevation": 30.0, "camera.azimuth": 90.0}).camera
    assert np.allclose(camera.position, [5 * np.cos(np.pi / 6), 2.5, 0])
    assert path_point([[0, 0, 0], [2, 0, 0], [2, 2, 0]], 0.75) == [2, 1, 0]  # by length along the polyline
    rows = caustica.batch(sweep, tmp_path / "out")
    assert all("error" not in r for r in rows) and rows[1]["values"]["objects.ball.material"] == {"type": "mirror"}


def test_the_documented_sweep_is_valid(tmp_path):
    from caustica.batch.job import make_job

    text = (Path(__file__).parents[1] / "docs" / "batch.md").read_text()
    example = text.split("## Sweep files")[1].split("```toml")[1].split("```")[0]
    job, base = make_job(write_sweep(tmp_path, example.replace("studio.exr", "white")), tmp_path / "out")
    assert job.frames == 500 and job.seed == 7 and job.labels == ("id", "depth", "glass", "flow")
    assert len(job.variations) == 15 and job.files(3)["image"] == "glass/000003.png"


def test_torn_manifest_line_and_foreign_manifest(tmp_path, capsys):
    out = tmp_path / "out"
    caustica.batch("glass-sphere", out, 3, orbit=30, **FAST)
    with open(out / "manifest.jsonl", "a") as f:
        f.write('{"index": 2, "files": {"ima')  # what a kill in mid-write would leave
    seen = []
    rows = caustica.batch("glass-sphere", out, 3, orbit=30, progress=lambda s: seen.append(s.row["index"]), **FAST)
    assert seen == [] and len(rows) == 3 and (out / "manifest.jsonl").read_text().count("\n") == 3
    (out / "job.json").unlink()  # a manifest whose job is unknown belongs to no one we know
    code, err = run_cli(["batch", "glass-sphere", "-o", str(out), "--frames", "3", "--orbit", "30", "--size", "48x36",
                         "-t", "plain"], capsys)
    assert code == 2 and "another job" in err


def test_a_folder_in_use_is_refused(tmp_path):
    from caustica.batch.manifest import Manifest

    held = Manifest(tmp_path)
    held.lock()
    try:
        with pytest.raises(caustica.OutputError, match="another caustica batch is writing to"):
            caustica.batch("glass-sphere", tmp_path, 1, **FAST)
    finally:
        held.unlock()
    assert len(caustica.batch("glass-sphere", tmp_path, 1, **FAST)) == 1


def test_progress_is_a_bar_on_a_terminal_and_lines_elsewhere():
    import io

    from caustica.batch.job import Progress
    from caustica.batch.progress import ProgressDisplay

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    for stream in (Terminal(), io.StringIO()):
        display = ProgressDisplay(stream)
        state = Progress(total=4, done=1, skipped=1)
        for _ in range(3):
            state.rendered += 1
            state.done += 1
            display(state)
        display.close()
        text = stream.getvalue()
        if isinstance(stream, Terminal):
            assert "4/4" in text and "frame/s" in text and "batch" in text
        else:
            assert text.splitlines()[-1].startswith("frame 4/4 (") and "frames/s" in text and "\r" not in text


def test_sweep_files_resolve_beside_the_sweep(tmp_path, monkeypatch):
    from caustica.images import write_image

    folder = tmp_path / "data"
    folder.mkdir()
    (folder / "ball.toml").write_text("[camera]\nposition = [0, 0, 4]\n[[objects]]\nname = 'ball'\nshape = 'sphere'\n"
                                      "material = { type = 'glass', ior = 1.5 }\n")
    write_image(folder / "red.exr", np.tile(np.array([1.0, 0.0, 0.0], np.float32), (8, 16, 1)))
    sweep = write_sweep(folder, "scene = 'ball.toml'\nframes = 2\ntechnique = 'env-map'\nsize = [32, 24]\n"
                                "[environment]\nimage = { list = ['red.exr', 'white'], cycle = true }\n")
    monkeypatch.chdir(tmp_path)  # neither file is in the current folder
    rows = caustica.batch(Path("data") / sweep.name, "out", workers=2)
    corners = [pixels(tmp_path / "out", r)[0, 0] for r in rows]
    assert list(corners[0]) == [255, 0, 0] and list(corners[1]) == [255, 255, 255]
    assert rows[0]["values"]["environment.image"] == "red.exr"


def test_auto_records_the_planned_technique(tmp_path):
    rows = caustica.batch("caustic-sphere", tmp_path / "out", 2, orbit=20, size=SIZE)
    assert rows[0]["technique"] not in ("auto", "") and rows[0]["technique"] == rows[1]["technique"]
    assert "+" in rows[0]["technique"]  # a view technique with caustics for a glass ball over a lit floor


def test_another_jobs_folder_is_refused_unless_force(tmp_path, capsys):
    out = str(tmp_path / "out")
    base = ["batch", "caustic-sphere", "-o", out, "--size", "48x36", "-t", "plain", "--frames", "2"]
    assert run_cli(base, capsys)[0] == 0
    code, err = run_cli(base + ["--orbit", "30"], capsys)
    assert code == 2 and err.count("\n") == 1 and "another job" in err and "--force" in err
    assert run_cli(base + ["--orbit", "30", "--force"], capsys)[0] == 0
    assert [r["values"] for r in rows_of(Path(out))] == [{"camera.orbit": 0.0}, {"camera.orbit": 15.0}]


def test_failing_frame_is_recorded_and_exit_code_is_1(tmp_path, capsys):
    # Each value alone is a valid scene; frame 1 puts the scaled sphere beyond the +-1e6 limit.
    sweep = write_sweep(tmp_path, """
scene = "glass-sphere"
frames = 3
technique = "plain"
size = [48, 36]
[objects.sphere]
position = { list = [[0, 0, 0], [999000, 0, 0], [0, 0, 0]], cycle = true }
scale = { list = [1, 2000, 1], cycle = true }
""")
    code, err = run_cli(["batch", str(sweep), "-o", str(tmp_path / "out")], capsys)
    rows = rows_of(tmp_path / "out")
    assert code == 1 and [r["index"] for r in rows] == [0, 1, 2]
    assert "error" not in rows[0] and "error" not in rows[2] and "reaches" in rows[1]["error"]
    assert "files" not in rows[1] and rows[1]["values"]["objects.sphere.scale"] == 2000.0


BAD_SWEEPS = [
    ("[objects.sphere]\niorr = 1.4\n", "unknown key 'iorr'", "did you mean 'ior'"),
    ("[objects.sphere]\nior = { uniform = [1.8, 1.3] }\n", "min 1.8 is above max 1.3", "[min, max]"),
    ("[objects.sphere]\nior = { list = ['glass', 'water'] }\n", "objects.sphere.ior.list[0] must be a finite number",
     "'glass'"),
    ("frames = 0\n", "frames must be in [1,", "0"),
    ("output = '../escape_{index}'\n", "outside the output folder", "without '..'"),
    ("output = 'frame'\n", "must use {index}", "frame_{index:06d}"),
    ("[objects.spere]\nior = 1.4\n", "no object 'spere'", "did you mean 'sphere'"),
    ("[objects.sphere]\nior = { uniform = [1.2, 20] }\n", "objects.sphere.ior = 20", "ior"),
    ("[camera]\nfov = 30\n", "unknown key 'fov'", "fov_y"),
    ("antialias = 'fxaa'\n", "antialias 'fxaa' is unknown", "choose one of none, edge, msaa, adaptive"),
    # An exporter's dotted name (Blender's Sphere.001) unquoted: TOML reads a table '001' in object 'Sphere'.
    ("[objects.sphere.001]\nior = 1.4\n", "read as object 'sphere' with a table '001'", '[objects."sphere.001"]'),
    # A relative image path is resolved against the sweep file's folder, and the error says so.
    ("[environment]\nimage = 'studio.exr'\n", "studio.exr': environment file not found", "relative to the sweep file"),
]


@pytest.mark.parametrize("body, problem, fix", BAD_SWEEPS)
def test_bad_sweep_files_are_one_line_errors(tmp_path, capsys, body, problem, fix):
    sweep = write_sweep(tmp_path, "scene = 'glass-sphere'\n" + body)
    code, err = run_cli(["batch", str(sweep), "-o", str(tmp_path / "out")], capsys)
    assert code == 2 and err.count("\n") == 1 and err.startswith("caustica: "), err
    assert problem in err and fix in err, err
    assert not (tmp_path / "out").exists()


def test_antialias_msaa_frames_are_the_renderers(tmp_path):
    """``antialias`` (argument or sweep setting) renders each frame as ``Renderer.render(..., antialias=...)``
    does, and is part of the job's description (another value is another job)."""
    from caustica.images import read_image

    with caustica.Renderer(SIZE) as renderer:
        scene = caustica.load_scene("door-mirror")
        expected = renderer.render(scene, "plain", 1, antialias="msaa")
        assert not np.allclose(expected, renderer.render(scene, "plain", 1), atol=1e-3)  # msaa changes the frame
    rows = caustica.batch("door-mirror", tmp_path / "api", 1, antialias="msaa", image_format="exr", **FAST)
    sweep = write_sweep(tmp_path, "scene = 'door-mirror'\nantialias = 'msaa'\nimage_format = 'exr'\n"
                                  "technique = 'plain'\nsize = [48, 36]\n")
    swept = caustica.batch(sweep, tmp_path / "sweep")
    for folder, row in ((tmp_path / "api", rows[0]), (tmp_path / "sweep", swept[0])):
        assert np.allclose(read_image(folder / row["files"]["image"]), expected, atol=1e-3)
        assert json.loads((folder / "job.json").read_text())["job"]["antialias"] == "msaa"
    with pytest.raises(caustica.CausticaError, match="another job"):
        caustica.batch("door-mirror", tmp_path / "api", 1, antialias="edge", image_format="exr", **FAST)


def test_a_bad_antialias_is_refused_before_any_frame(tmp_path, capsys):
    code, err = run_cli(["batch", "glass-sphere", "-o", str(tmp_path / "out"), "--antialias", "fxaa"], capsys)
    assert code == 2 and err.count("\n") == 1 and "invalid choice: 'fxaa'" in err and "msaa" in err, err
    with pytest.raises(caustica.CausticaError, match=r"^antialias 'fxaa' is unknown; choose one of none, edge, msaa, adaptive$"):
        caustica.batch("glass-sphere", tmp_path / "out", 1, antialias="fxaa")
    assert not (tmp_path / "out").exists()


def test_bad_options_are_one_line_errors(tmp_path, capsys):
    out = str(tmp_path / "out")
    for args, problem in ((["--frames", "0"], "out of range"), (["--workers", "0"], "out of range"),
                          (["--workers", "2", "--ray", "local"], "not both"), (["-t", "nope"], "nope")):
        code, err = run_cli(["batch", "glass-sphere", "-o", out] + args, capsys)
        assert code == 2 and err.count("\n") == 1 and problem in err, err
    with pytest.raises(caustica.CausticaError, match="workers must be a positive integer"):
        caustica.batch("glass-sphere", out, 1, workers=0)


def test_unknown_label_is_one_line(tmp_path, capsys):
    code, err = run_cli(["batch", "glass-sphere", "-o", str(tmp_path), "--labels", "id,dept"], capsys)
    assert code == 2 and err.count("\n") == 1 and "did you mean 'depth'" in err


@pytest.mark.parametrize("fmt", ["exr", "npz"])
def test_labels_are_the_frames_layers(tmp_path, fmt):
    from caustica.batch.edits import SceneEditor
    from caustica.batch.job import make_job
    from caustica.labels import read_labels

    names = ["id", "depth", "normal", "glass", "flow", "alpha"]
    rows = caustica.batch("caustic-sphere", tmp_path, 2, orbit=40, labels=names, labels_format=fmt, size=SIZE,
                          technique="env-map", workers=2 if fmt == "npz" else 1)
    job, base = make_job("caustic-sphere", tmp_path, frames=2, orbit=40)
    for row in rows:
        path = tmp_path / row["files"]["labels"]
        assert path.name == f"frame_{row['index']:06d}.labels.{fmt}" and path.stat().st_size == row["sizes"]["labels"]
        scene = SceneEditor(base).apply(job.values(row["index"]))
        _, expected = caustica.Renderer(SIZE).render(scene, "env-map", 1, labels=names)
        written = read_labels(path)
        assert set(written) == set(expected)
        for name in expected:
            assert np.array_equal(written[name], expected[name]), name
    ids = read_labels(tmp_path / rows[0]["files"]["labels"])["id"]
    assert set(np.unique(ids)) == {-1, 0, 1}  # background, ball, floor


def egl(index: int, *extensions: str, cuda: int | None = None):
    from caustica.batch.devices import EglDevice

    return EglDevice(index, frozenset(extensions), cuda)


NV, SOFT = "EGL_NV_device_cuda", "EGL_MESA_device_software"


def test_workers_take_turns_on_the_devices():
    from caustica.batch.devices import assign, gpus

    assert assign(5, [0, 1]) == [0, 1, 0, 1, 0] and assign(2, [3]) == [3, 3] and assign(1, [2, 0]) == [2]
    assert gpus([egl(0, NV), egl(1, NV), egl(2, SOFT)]) == [0, 1]  # NVIDIA's GPUs, not Mesa's llvmpipe
    assert gpus([egl(0, SOFT), egl(1, "EGL_EXT_device_drm")]) == [1]  # a Mesa GPU
    assert gpus([egl(0, SOFT)]) == [0] and gpus([]) == [0]  # llvmpipe where there is nothing else


def test_placement_checks_the_devices(monkeypatch):
    from caustica.batch.devices import ENV, placement

    monkeypatch.delenv(ENV, raising=False)
    two = [egl(0, NV, cuda=1), egl(1, NV, cuda=0), egl(2, SOFT)]
    assert placement(None, two) == [0, 1] and placement("2, 0", two) == [2, 0] and placement([1], two) == [1]
    with pytest.raises(caustica.CausticaError, match=r"no EGL device 7 on this machine \(EGL lists 3, indices 0 to 2"):
        placement([7], two)
    with pytest.raises(caustica.CausticaError, match="must be EGL device indices"):
        placement("a,b", two)
    monkeypatch.setenv(ENV, "2")
    assert placement(None, two) == [2]
    monkeypatch.setenv(ENV, "9")
    with pytest.raises(caustica.CausticaError, match=f"{ENV}='9': there is no EGL device 9"):
        placement(None, two)


def test_ray_gpus_map_to_egl_devices_by_cuda_ordinal():
    from caustica.batch.devices import ray_device

    listed = [egl(0, NV, cuda=1), egl(1, NV, cuda=0), egl(2, SOFT)]  # EGL's order is not CUDA's
    assert ray_device([0], listed) == 1 and ray_device(["1"], listed) == 0
    assert ray_device([1], [egl(0, NV), egl(1, NV, cuda=0)]) == 1  # the one GPU the driver lets CUDA see
    assert ray_device([3], [egl(0, NV), egl(1, NV), egl(2, SOFT)]) == 1  # no ordinals: EGL's order, round robin
    assert ray_device(["GPU-5d1c"], listed) == 0 and ray_device([], listed) is None


def test_devices_pin_spawned_workers_and_land_in_the_manifest(tmp_path, capsys):
    out = tmp_path / "out"
    code, err = run_cli(["batch", "glass-sphere", "-o", str(out), "--frames", "2", "--size", "16x16", "-t", "plain",
                         "--devices", "0,0"], capsys)
    assert code == 0, err
    rows = rows_of(out)
    assert [r["device"] for r in rows] == [0, 0] and rows[0]["renderer"] == rows[1]["renderer"] != ""
    assert len({r["worker"] for r in rows}) == 2 and os.getpid() not in {r["worker"] for r in rows}  # one per device
    code, err = run_cli(["batch", "glass-sphere", "-o", str(tmp_path / "none"), "--devices", "7"], capsys)
    assert code == 2 and err.count("\n") == 1 and "no EGL device 7 on this machine" in err, err
    assert not (tmp_path / "none").exists()
    code, err = run_cli(["batch", "glass-sphere", "-o", str(tmp_path / "none"), "--devices", "0", "--ray", "local"],
                        capsys)
    assert code == 2 and "not both" in err


@pytest.mark.slow
def test_the_same_job_on_a_local_ray(tmp_path):
    pytest.importorskip("ray", reason="Ray is not installed (pip install 'caustica[batch]')")
    inline = caustica.batch("caustic-sphere", tmp_path / "inline", 6, orbit=60, **FAST)
    rows = caustica.batch("caustic-sphere", tmp_path / "ray", 6, orbit=60, ray="local", **FAST)
    assert [r["index"] for r in rows] == list(range(6)) and len(rows_of(tmp_path / "ray")) == 6
    assert os.getpid() not in {r["worker"] for r in rows}
    for a, b in zip(inline, rows):
        assert np.array_equal(pixels(tmp_path / "inline", a), pixels(tmp_path / "ray", b))
