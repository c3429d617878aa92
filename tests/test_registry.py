"""The technique registry (techniques/registry.py): a technique is registered by declaring it, and the lists of
view techniques per-object offers and the composites suggest come from the declarations."""
from __future__ import annotations

import gc

import pytest

from caustica.errors import TechniqueError
from caustica.techniques import get_technique, technique_names
from caustica.techniques.base import ROLES, Technique
from caustica.techniques.composite import CausticTechnique, Composite
from caustica.techniques.env_map import EnvMap
from caustica.techniques.raster import RasterTechnique
from caustica.techniques.registry import registered, view_technique_names


def test_every_declared_technique_is_registered_under_its_role():
    classes = registered()
    assert all(cls.name == name and cls.role in ROLES for name, cls in classes.items())
    assert {n for n, cls in classes.items() if cls.role == "caustics"} == {
        n for n in classes if isinstance(get_technique(n), CausticTechnique)}
    assert classes["auto"].role == "planner" and classes["exact"].role == classes["mitsuba"].role == "reference"
    # Base classes without a name of their own, and composites (named per instance), are not registered.
    assert not {Technique, RasterTechnique, CausticTechnique, Composite} & set(classes.values())


def test_view_techniques_come_from_view_order():
    views = view_technique_names()
    assert [n for n in views if n in ("env-map", "image-space", "depth-search")] == ["env-map", "image-space",
                                                                                   "depth-search"]
    assert [registered()[n].view_order for n in views] == sorted(registered()[n].view_order for n in views)
    assert all(registered()[n].role == "view" for n in views)


def test_a_declared_technique_joins_the_lookup_and_the_lists():
    before = view_technique_names()

    class Tinted(EnvMap):  # env-map under another name, placed right after it among the view techniques
        name = "test-tinted"
        summary = "env-map under another name"
        view_order = EnvMap.view_order + 1

    try:
        _joins_the_lookup_and_the_lists(Tinted, before)
    finally:
        del Tinted
        gc.collect()  # the registry holds no reference: the class leaves it with its last one
    assert "test-tinted" not in technique_names() and view_technique_names() == before


def _joins_the_lookup_and_the_lists(declared, before):
    assert "test-tinted" in technique_names()
    assert isinstance(get_technique("test-tinted"), declared)
    at = before.index("env-map") + 1
    views = (*before[:at], "test-tinted", *before[at:])
    assert view_technique_names() == views
    composite = get_technique("test-tinted+caustic-mapping")
    assert isinstance(composite, Composite) and isinstance(composite.view, declared)
    with pytest.raises(TechniqueError, match=rf"; use {', '.join(views[:-1])} or {views[-1]}$"):
        get_technique("exact+caustic-mapping")


def test_declarations_are_checked_when_the_class_is_made():
    with pytest.raises(TypeError, match=r"technique 'test-odd' declares role 'shiny'; give one of view, caustics"):
        type("Odd", (RasterTechnique,), {"name": "test-odd", "role": "shiny"})
    with pytest.raises(TypeError, match=r"'test-late' declares a view_order but its role is 'caustics'"):
        type("Late", (CausticTechnique,), {"name": "test-late", "view_order": 5})
    with pytest.raises(TypeError, match=r"technique 'test-cpu' declares role ''"):
        type("Cpu", (Technique,), {"name": "test-cpu"})  # a CPU technique states what it is
    gc.collect()
    assert not {"test-odd", "test-late", "test-cpu"} & set(technique_names())
