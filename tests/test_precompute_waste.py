"""`caustica precompute` spends its time on the table (issue 43: of the bunny's 25 s, 6 s went to quantizing
and comparing in table-sized float64 temporaries and deflating the same 54 MB twice): quantization and its
error report run block by block with the same results, and the file is serialised once for both copies."""
from __future__ import annotations

import numpy as np
import trimesh

import caustica.transport.compress as compress
from caustica.cli import main
from caustica.scene.shapes import sphere
from caustica.transport.precompute import precompute_table


def test_blocks_change_neither_the_quantized_table_nor_its_errors(monkeypatch):
    table = precompute_table(sphere(0.5, subdivisions=2), 1.5, directions=9, progress=False)
    table.exit_position += np.float32(3e-5)  # off the quantization grid
    whole, whole_errors = compress.quantize(table), compress.quantization_errors(table)
    monkeypatch.setattr(compress, "BLOCK_SAMPLES", 7 * 9 + 5)  # 7 vertices a block, a short last one
    assert len(compress._blocks(table)) > 10
    blocked = compress.quantize(table)
    for name in ("position", "direction", "transmittance"):
        assert np.array_equal(getattr(blocked, name), getattr(whole, name)), name
    assert compress.quantization_errors(table, blocked) == whole_errors
    assert whole_errors["position_error_percent"] > 0


def test_precompute_serialises_the_table_once_for_both_files(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("CAUSTICA_CACHE", str(tmp_path / "cache"))
    mesh = sphere(0.5, subdivisions=2)
    trimesh.Trimesh(mesh.vertices, mesh.faces, vertex_normals=mesh.normals, process=False).export(tmp_path / "b.obj")
    calls = []
    real = compress.table_bytes
    monkeypatch.setattr(compress, "table_bytes", lambda q: calls.append(q) or real(q))
    out = tmp_path / "tables" / "b.npz"  # a missing folder: made once the table is done
    assert main(["precompute", str(tmp_path / "b.obj"), "--ior", "1.5", "--directions", "9", "-o", str(out)]) == 0
    assert len(calls) == 1
    cached = list((tmp_path / "cache" / "transport").glob("*.npz"))
    assert len(cached) == 1 and cached[0].read_bytes() == out.read_bytes()
    assert np.array_equal(compress.load_table(out).position, calls[0].position)
