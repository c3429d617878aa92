"""Parameters are declared once (caustica.parameters.param): the listing, the validation, the viewer's
controls and docs/techniques.md all come from that declaration."""
from __future__ import annotations

import json

import pytest

from caustica import TechniqueError
from caustica.cli import main
from caustica.docs_techniques import DOCS_PATH, markdown
from caustica.techniques import get_technique, technique_names


def listing(capsys, *args) -> object:
    assert main(["techniques", "--json", *args]) == 0
    return json.loads(capsys.readouterr().out)


def declared_rows():
    """(technique, row) for every parameter of every technique, as ``caustica techniques --json`` gives them."""
    from caustica.docs_techniques import catalogue

    return [(info["name"], row) for info in catalogue() for row in info["parameters"]]


ROWS = declared_rows()
IDS = [f"{t}-{r['name']}" for t, r in ROWS]


def test_json_lists_every_parameter_of_every_technique(capsys):
    import dataclasses

    infos = {info["name"]: info for info in listing(capsys)}
    assert set(infos) == set(technique_names())
    for name, info in infos.items():
        fields = [f.name for f in dataclasses.fields(get_technique(name).Params)]
        assert [row["name"] for row in info["parameters"]] == fields, name
        assert info["summary"]
        for row in info["parameters"]:
            assert row["type"] and row["help"] and "default" in row and "unit" in row and "paper" in row, row
            if row["type"] in ("int", "float", "rgb"):
                assert len(row["range"]) == 2 and row["range"][0] <= row["range"][1] and row["ends"], row
            elif row["type"] in ("choice", "mapping"):
                assert row["choices"], row
            else:
                assert row["type"] == "bool", row


def test_json_and_table_for_one_technique(capsys):
    info = listing(capsys, "caustic-mapping")
    photon_grid = next(r for r in info["parameters"] if r["name"] == "photon_grid")
    assert photon_grid["special"] == [{"value": 0, "means": "= map_size"}] and photon_grid["paper"].startswith("Shah")
    assert main(["techniques", "depth-search"]) == 0
    out = capsys.readouterr().out
    assert "search_start" in out and "(0, 2]" in out and "Hu and Qin 2.1.2" in out
    assert main(["techniques", "depth-search+caustic-mapping"]) == 0
    assert "photon_grid" in capsys.readouterr().out
    assert main(["techniques"]) == 0 and "env-map" in capsys.readouterr().out


@pytest.mark.parametrize("technique, row", ROWS, ids=IDS)
def test_the_declared_default_passes_its_own_validation(technique, row):
    if row["type"] == "mapping":
        return
    params = get_technique(technique).make_params(**{row["name"]: row["default"]})
    assert getattr(params, row["name"]) == getattr(get_technique(technique).make_params(), row["name"])


def _outside(row):
    """Values just outside the declared range, each side (none on an infinite side)."""
    low, high = row["range"]
    if row["type"] == "int":
        return [low - 1, high + 1]
    values = [low if row["ends"][0] == "(" else low - max(abs(low), 1.0) * 1e-6,
              high if row["ends"][1] == ")" else high + max(abs(high), 1.0) * 1e-6]
    return [[v, v, v] for v in values] if row["type"] == "rgb" else values


RANGED = [(t, r) for t, r in ROWS if "range" in r]


@pytest.mark.parametrize("technique, row", RANGED, ids=[f"{t}-{r['name']}" for t, r in RANGED])
def test_each_declared_range_is_enforced(technique, row):
    specials = [s["value"] for s in row.get("special", ())]
    for value in _outside(row):
        if value in specials:
            continue
        with pytest.raises(TechniqueError, match=rf"\b{row['name']}\b"):
            get_technique(technique).make_params(**{row["name"]: value})
    low, high = row["range"]
    inside = [x for x in (low, high) if row["ends"][0 if x == low else 1] in "[]"]
    if row["name"] == "directions":
        inside = [low]  # also 2 r^2 + 1 (a rule of its own): 3 is, 100000 is not
    for value in inside:
        get_technique(technique).make_params(**{row["name"]: [value] * 3 if row["type"] == "rgb" else value})


CHOICES = [(t, r) for t, r in ROWS if r["type"] == "choice"]


@pytest.mark.parametrize("technique, row", CHOICES, ids=[f"{t}-{r['name']}" for t, r in CHOICES])
def test_choices_are_enforced(technique, row):
    technique_ = get_technique(technique)
    with pytest.raises(TechniqueError, match=rf"{row['name']} 'bogus' must be one of {', '.join(row['choices'])}"):
        technique_.make_params(**{row["name"]: "bogus"})
    for choice in row["choices"]:
        if technique.startswith("impostor") and row["name"] == "nearby" and choice != "none":
            continue  # the impostors are their own nearby geometry: a cross-rule of theirs
        assert getattr(technique_.make_params(**{row["name"]: choice}), row["name"]) == choice


def test_special_values_outside_the_range_are_accepted():
    assert get_technique("caustic-mapping").make_params(photon_grid=0, map_size=64).photon_grid == 64
    assert get_technique("per-vertex").make_params(map_size=0).map_size == 0
    assert get_technique("mitsuba").make_params(max_depth=-1).max_depth == -1
    assert get_technique("impostor-caustics").make_params(filter_s=None).filter_s is None
    with pytest.raises(TechniqueError, match=r"max_depth False must be -1 \(unbounded\) or an integer in \[1, 1024\]"):
        get_technique("mitsuba").make_params(max_depth=False)  # False == 0, but is no special value


def test_viewer_controls_come_from_the_declaration():
    from caustica.viewer.params import param_specs

    specs = {s.name: s for s in param_specs(get_technique("caustic-mapping"))}
    assert (specs["photon_grid"].low, specs["photon_grid"].high) == (0, 4096)  # 0: = map_size
    assert specs["estimator"].choices == ("iterate", "newton")
    per_vertex = {s.name: s for s in param_specs(get_technique("per-vertex"))}
    assert per_vertex["ior_rgb"].kind == "other" and per_vertex["up"].kind == "choice"


def test_docs_techniques_md_is_current():
    assert DOCS_PATH.read_text(encoding="utf-8") == markdown(), \
        "docs/techniques.md is stale: run python -m caustica.docs_techniques"
