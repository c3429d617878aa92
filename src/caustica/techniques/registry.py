"""The technique registry: every technique by its name, and ``view+caustics`` composites.

A technique is registered by declaring it: a subclass of Technique with a ``name`` of its own,
in a module of this package (imported here on the first lookup) or anywhere else. The lists
of view and caustic techniques come from their declarations (``role``, ``view_order``), not
from lists kept by hand.
"""
from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path

from ..errors import TechniqueError, closest_name, short
from .base import Technique

_loaded = False


def _load_builtin() -> None:
    """Import every module of this package once: each technique declares itself by subclassing."""
    global _loaded
    if _loaded:
        return
    for info in pkgutil.iter_modules([str(Path(__file__).parent)]):
        importlib.import_module(f"{__package__}.{info.name}")
    _loaded = True


def registered() -> dict[str, type[Technique]]:
    """Name -> class of every declared technique; of two classes declaring one name under the same
    parent class, the later."""
    _load_builtin()
    found, pending = {}, [Technique]
    while pending:
        for cls in pending.pop(0).__subclasses__():
            if "name" in vars(cls) and cls.name:
                found[cls.name] = cls
            pending.append(cls)
    return found


def technique_names() -> list[str]:
    """Every registered technique's name, sorted."""
    return sorted(registered())


def view_technique_names() -> tuple[str, ...]:
    """The view techniques per-object offers a glass object (those declaring a ``view_order``), in that order."""
    views = [cls for cls in registered().values() if cls.view_order is not None]
    return tuple(cls.name for cls in sorted(views, key=lambda cls: (cls.view_order, cls.name)))


def get_technique(name: str) -> Technique:
    """A technique by name; ``view+caustics`` composes a view technique with a caustic technique. A
    Technique instance (one built in code, e.g. a Composite) is returned as it is."""
    if isinstance(name, Technique):
        return name
    if not isinstance(name, str):
        raise TechniqueError(f"technique {short(name)} must be a technique name such as 'env-map'; "
                             "run 'caustica techniques' to list them")
    if "+" in name:
        return _composite(name)
    techniques = registered()
    if name not in techniques:
        raise TechniqueError(
            f"unknown technique {short(name)}{closest_name(name, techniques)}; run 'caustica techniques' to list them"
        )
    return techniques[name]()


def _composite(name: str) -> Technique:
    """``view+caustics`` -> the caustic technique composed with the view (composite.py), or a TechniqueError
    naming what is wrong."""
    parts = name.split("+")
    if len(parts) != 2 or not all(parts):
        raise TechniqueError(f"technique '{name}' must be 'view+caustics', e.g. 'depth-search+caustic-mapping'")
    view, caustics = get_technique(parts[0]), get_technique(parts[1])
    if view.role != "view":
        *others, last = view_technique_names()
        raise TechniqueError(f"'{parts[0]}' cannot show the camera view in '{name}'; use {', '.join(others)} or {last}")
    if caustics.role != "caustics":
        raise TechniqueError(f"'{parts[1]}' makes no caustics in '{name}'; use a caustic technique after the '+'")
    return caustics.composed_with(view)
