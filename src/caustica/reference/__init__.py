"""Ground truth from Mitsuba 3: the same scene exported and path / light traced.

``render_reference(scene, size=None, spp=256)`` returns the composite reference
image (see :mod:`caustica.reference.render`); ``scene_to_mitsuba`` the scene
dict; ``write_mitsuba_xml(scene, path)`` a Mitsuba 3 XML file (docs/reference.md).
Importing this package does not import Mitsuba.
"""
from .mitsuba_export import scene_to_mitsuba, write_mitsuba_xml
from .render import render_reference

__all__ = ["render_reference", "scene_to_mitsuba", "write_mitsuba_xml"]
