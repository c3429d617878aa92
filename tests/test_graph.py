"""The render graph (render/graph.py): wiring, lending and giving back, caching across frames, `caustica graph`."""
from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from caustica import Renderer
from caustica.gpu.device import gl_objects
from caustica.render.frame import Channel, Frame, Pass, PassWiringError
from caustica.render.graph import RenderGraph, run_graph
from caustica.scene.presets import PRESETS
from caustica.techniques import get_technique, technique_names

SRC = Path(__file__).resolve().parents[1] / "src" / "caustica"

# Each GPU technique on a preset it has work to do in (glass, mirrors, lenses, caustic casters).
TECHNIQUE_SCENES = {
    "env-map": "caustics-point", "plain": "caustics-point", "image-space": "glass-sphere",
    "depth-search": "tvcg-fig10", "impostors": "tvcg-fig14", "per-vertex": "spectacle-convex",
    "per-object": "glass-sphere", "caustic-mapping": "caustics-two-lights", "photon-splats": "caustics-spot",
    "impostor-caustics": "tvcg-fig24", "transport-table": "transport-ball", "transport-table-view": "transport-ball",
    "impostors+impostor-caustics": "tvcg-fig27", "image-space+caustic-mapping": "caustics-point",
    "auto": "caustic-sphere",
}


def cached_pool_textures(device) -> int:
    """Pooled textures the device cache holds across frames (impostor atlases): lent, but to the cache."""
    return sum(1 for obj in gl_objects(list(device.cache.values())) if device.targets.is_lent(obj))


def test_every_gpu_technique_is_covered():
    gpu = {n for n in technique_names() if get_technique(n).uses_gl}
    assert gpu <= set(TECHNIQUE_SCENES)


@pytest.mark.parametrize("technique", sorted(TECHNIQUE_SCENES))
def test_no_texture_is_left_lent_after_a_frame(technique):
    """After any technique's frame, the only textures out of the pool are those the cache holds."""
    scene = PRESETS[TECHNIQUE_SCENES[technique]]()
    with Renderer((48, 40)) as renderer:
        for spp in (1, 4):
            renderer.render(scene, technique, spp=spp)
            device = renderer.device
            assert device.targets.counts()["lent_textures"] == cached_pool_textures(device)
        # Keeping the channels lends them until the next frame, which gives them back.
        keeper = Renderer((48, 40), keep_channels=True, device=device)
        keeper.render(scene, technique)
        assert device.targets.counts()["lent_textures"] > cached_pool_textures(device)
        keeper.close()
        assert device.targets.counts()["lent_textures"] == cached_pool_textures(device)


class Allocates(Pass):
    """Lends a texture to each channel it writes."""

    def __init__(self, *names, reads=()):
        self.writes = tuple(Channel(n, "r32f", "a texture") for n in names)
        self.reads = tuple(reads)
        self.seen = {}

    def run(self, frame):
        for name in self.reads:  # what this pass reads is still lent to the frame when it runs
            self.seen[name] = id(frame.read(name)) in frame.lent
        frame.texture((4, 4), "r32f")  # scratch no channel holds: given back when the pass ends
        for channel in self.writes:
            frame.write(channel.name, frame.texture((4, 4), "r32f"))


def test_a_channel_goes_back_after_its_last_reader(renderer):
    device = renderer.device
    before = device.targets.counts()["lent_textures"]
    first, second, third = Allocates("a", "b"), Allocates("c", reads=("a",)), Allocates("d", reads=("a", "c"))
    frame = Frame(device, None, None, None)
    run_graph([first, second, third], frame, keep=("d",))
    assert second.seen == {"a": True} and third.seen == {"a": True, "c": True}
    # Only the kept channel is still lent: 'b' (never read), 'a' and 'c' (read by pass 3), scratch gone.
    assert list(frame.lent.values()) == [frame.read("d")]
    assert device.targets.counts()["lent_textures"] == before + 1
    frame.give_back()
    assert device.targets.counts()["lent_textures"] == before


def test_a_failing_frame_gives_everything_back(renderer):
    class Fails(Pass):
        reads = ("a",)

        def run(self, frame):
            frame.texture((4, 4), "r32f")
            raise RuntimeError("boom")

    from caustica.techniques.raster import RasterTechnique

    class Wrapped(RasterTechnique):  # a technique whose second pass fails (no name: not registered)
        def build_passes(self, params):
            return [Allocates("a"), Fails()]

    device = renderer.device
    before = device.targets.counts()["lent_textures"]
    with pytest.raises(RuntimeError, match="boom"):
        renderer.render_frame(Wrapped(), PRESETS["glass-sphere"](), PRESETS["glass-sphere"]().camera, None)
    assert device.targets.counts()["lent_textures"] == before


class Keyed(Pass):
    """A cached pass: its output depends on ``key`` alone."""

    writes = (Channel("value", "r32f", "a texture"),)

    def __init__(self):
        self.key, self.runs = 0, 0

    def cache_key(self, frame):
        return self.key

    def run(self, frame):
        self.runs += 1
        frame.write("value", frame.texture((4, 4), "r32f"))


def test_a_cached_pass_runs_once_per_key_and_its_old_output_goes_back(renderer):
    device = renderer.device
    before = device.targets.counts()["lent_textures"]
    stage = Keyed()
    outputs = []
    for key in (1, 1, 1, 2, 2):
        stage.key = key
        frame = Frame(device, None, None, None)
        run_graph([stage], frame, keep=())
        outputs.append(frame.read("value"))
        assert not frame.lent  # the cache holds the output, not the frame
    assert stage.runs == 2
    assert outputs[0] is outputs[1] is outputs[2] and outputs[3] is outputs[4]
    # One entry per pass: the key-1 texture went back to the pool when key 2 missed (and the pool
    # lent it again for key 2's run), so one texture is out, not two.
    assert [k for k in device.cache if k[0] == stage.label] == [(stage.label, 2)]
    assert device.targets.counts()["lent_textures"] == before + 1
    device.cache.pop_release((stage.label, 2))
    assert device.targets.counts()["lent_textures"] == before


def test_optional_inputs_set_their_defines():
    class Shades(Pass):
        optional = {"caustic_maps": "CAUSTICS"}
        writes = (Channel("color", "rgba32f", "an image"),)

        def run(self, frame):
            frame.write("color", frame.optional_defines())

    for provided, expected in (({}, 0), ({"caustic_maps": [object()]}, 1)):
        frame = Frame(None, None, None, None, channels=dict(provided))
        run_graph([Shades()], frame)
        assert frame.read("color") == {"CAUSTICS": expected}


def test_channel_formats_are_real_formats():
    with pytest.raises(ValueError, match="not a channel format"):
        Channel("maps", "list", "per light")
    with pytest.raises(ValueError, match="not a channel format"):
        Channel("impostors", "ImpostorSet", "rectangles")
    for fmt in ("rgba32f", "depth", "r32f[light]", "rgba32f x2[light]", "buffer[light]", "host", "rgba32f + host[reflector]"):
        Channel("ok", fmt, "fine")


@pytest.mark.parametrize("technique", sorted(TECHNIQUE_SCENES))
def test_every_graph_is_wired_and_described(technique):
    tech = get_technique(technique)
    tech, params = tech.for_scene(PRESETS[TECHNIQUE_SCENES[technique]](), tech.make_params())  # auto: its plan
    graph = RenderGraph(tech.build_passes(params))
    graph.check()  # every read is written earlier, with no channel given by the caller
    text = graph.describe()
    for stage in graph.passes:
        assert stage.label in text
        for channel in stage.writes:
            assert f"{channel.name} ({channel.format})" in text
    assert "color (rgba32f)" in text and "kept for the caller" in text
    dot = graph.dot(technique)
    assert dot.startswith("digraph") and dot.count("[label=") >= len(graph.passes)


def test_a_miswired_graph_is_refused_before_it_runs():
    with pytest.raises(PassWiringError, match="reads"):
        RenderGraph([Allocates("b", reads=("a",))]).check()


def test_techniques_never_import_the_renderer():
    """Techniques list passes; the renderer runs them (no import circle)."""
    for path in sorted((SRC / "techniques").glob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                assert "renderer" not in (node.module or ""), f"{path.name} imports {node.module}"
            elif isinstance(node, ast.Import):
                assert not any("renderer" in alias.name for alias in node.names), path.name


def test_no_pass_frees_by_hand():
    """Passes and techniques allocate through the frame; only the frame and the graph give back."""
    for folder in ("passes", "techniques"):
        for path in sorted((SRC / folder).glob("*.py")):
            if path.name in ("base.py", "graph.py"):
                continue
            text = path.read_text()
            for call in ("targets.give_back(", "targets.texture(", "targets.zeroed(", ".release()"):
                assert call not in text, f"{folder}/{path.name} calls {call}"


def test_graph_command_prints_and_writes_dot(tmp_path, capsys):
    from caustica.cli import main

    assert main(["graph", "depth-search+caustic-mapping"]) == 0
    out = capsys.readouterr().out
    assert "CachedPasses(caustic-mapping)" in out and "[cached across frames]" in out
    assert "caustic_maps (define CAUSTICS)" in out and "ResolveCausticMaps" in out
    target = tmp_path / "graph.dot"
    assert main(["graph", "impostors", "-p", "depth=1", "--dot", str(target)]) == 0
    assert target.read_text().startswith('digraph "impostors"')
    assert main(["graph", "exact"]) == 2
    assert "no render graph" in capsys.readouterr().err
    assert main(["graph", "auto"]) == 2
    assert "add --scene" in capsys.readouterr().err
    assert main(["graph", "auto", "--scene", "caustic-sphere"]) == 0
    assert "impostors+caustic-mapping" in capsys.readouterr().out
    assert main(["graph", "depth-serch"]) == 2
    assert "depth-search" in capsys.readouterr().err


def test_cached_passes_give_the_same_image_on_the_next_frame():
    """The second frame reuses the shadow maps, caustic maps and impostors the first one cached."""
    for preset, technique in (("caustics-point", "caustic-mapping"), ("tvcg-fig14", "impostors")):
        scene = PRESETS[preset]()
        with Renderer((40, 32), profile_passes=True) as renderer:
            first = renderer.render(scene, technique)
            cached = len(renderer.device.cache)
            second = renderer.render(scene, technique)
            assert len(renderer.device.cache) == cached >= 2
        assert np.array_equal(first, second)
