"""Parameter controls built from a technique's ``Params`` dataclass, with no per-technique code.

Each field becomes a :class:`ParamSpec`: bool -> checkbox, int/float -> a drag
with a range, a ``Literal`` or a validated string choice -> a combo. Ranges and
choices come from the type hints where they say it, otherwise from the
dataclass's own validation: an out-of-range value is tried and the error's
``[lo, hi]`` or ``one of a, b, c`` is read back, so the panel always offers what
``__post_init__`` accepts.
"""
from __future__ import annotations

import dataclasses
import re
import typing
from dataclasses import dataclass

from ..errors import TechniqueError

_RANGE = re.compile(r"[\[(]\s*(-?[\d.eE+-]+)\s*,\s*(-?[\d.eE+-]+)\s*[\])]")
_CHOICES = re.compile(r"must be (?:one of )?(.+?)\s*(?:\(|;|$)")
_PROBES = {int: (10**9, -(10**9)), float: (1e30, -1e30)}


@dataclass
class ParamSpec:
    """One editable parameter: name, kind ('bool', 'int', 'float', 'choice'), default, range or choices."""

    name: str
    kind: str
    default: object
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()

    def clamp(self, value):
        """A value of the right type within the known range."""
        if self.kind == "bool":
            return bool(value)
        if self.kind == "choice":
            return str(value)
        value = round(value) if self.kind == "int" else float(value)
        if self.low is not None:
            value = max(value, type(value)(self.low))
        if self.high is not None:
            value = min(value, type(value)(self.high))
        return value

    @property
    def speed(self) -> float:
        """Drag speed: 1/200 of the range, or of the default's size."""
        if self.kind == "int":
            return 1.0 if self.high is None or self.high - (self.low or 0) < 2000 else 16.0
        span = (self.high - self.low) if self.low is not None and self.high is not None else abs(self.default or 1.0)
        return max(span / 200.0, 1e-4)


def param_specs(technique) -> list[ParamSpec]:
    """The controls of ``technique`` (a Technique instance, composites included), in field order."""
    parts = getattr(technique, "view", None), getattr(technique, "caustics", None)
    if all(parts):  # a view+caustics composite: the union of both, each name once
        specs, seen = [], set()
        for part in parts:
            for spec in param_specs(part):
                if spec.name not in seen:
                    seen.add(spec.name)
                    specs.append(spec)
        return specs
    params_type = technique.Params
    hints = typing.get_type_hints(params_type)
    return [_spec(technique, f, hints.get(f.name, type(_default(f)))) for f in dataclasses.fields(params_type)
            if f.init and not f.name.startswith("_")]


def _default(field: dataclasses.Field):
    if field.default is not dataclasses.MISSING:
        return field.default
    if field.default_factory is not dataclasses.MISSING:
        return field.default_factory()
    return None


def _spec(technique, field: dataclasses.Field, hint) -> ParamSpec:
    default = _default(field)
    if typing.get_origin(hint) is typing.Literal:
        return ParamSpec(field.name, "choice", default, choices=tuple(str(a) for a in typing.get_args(hint)))
    if hint is bool or isinstance(default, bool):
        return ParamSpec(field.name, "bool", default)
    if hint in (int, float) or isinstance(default, (int, float)):
        kind = "int" if (hint is int or isinstance(default, int)) else "float"
        low, high = _probe_range(technique, field.name, int if kind == "int" else float)
        if low is not None and default is not None and default < low:  # e.g. 0 meaning "automatic"
            low = default
        return ParamSpec(field.name, kind, default, low, high)
    if isinstance(default, str):
        return ParamSpec(field.name, "choice", default, choices=_probe_choices(technique, field.name, default))
    return ParamSpec(field.name, "other", default)


def _rejection(technique, name: str, value) -> str | None:
    """The validation message for ``name=value``, or None when the value is accepted."""
    try:
        technique.make_params(**{name: value})
    except (TechniqueError, TypeError, ValueError) as exc:
        return str(exc)
    return None


def _probe_range(technique, name: str, kind) -> tuple[float | None, float | None]:
    """[low, high] as the validation message states it; a side with no message stays open."""
    for probe in _PROBES[kind]:
        message = _rejection(technique, name, probe)
        match = _RANGE.search(message or "")
        if match:
            return float(match.group(1)), float(match.group(2))
    low = 0.0 if _rejection(technique, name, kind(-1)) else None
    return low, None


def _probe_choices(technique, name: str, default: str) -> tuple[str, ...]:
    """The accepted strings, read from the message for an unknown one; just the default otherwise."""
    match = _CHOICES.search(_rejection(technique, name, "\x00?") or "")
    if not match:
        return (default,)
    choices = [c.strip().strip("'\"") for c in re.split(r",\s*(?:or\s+)?|\s+or\s+", match.group(1)) if c.strip()]
    if not choices or any(" " in c for c in choices):  # a sentence, not a list of names
        return (default,)
    return tuple(choices) if default in choices else (default, *choices)


# Scene materials and lights: the fields a panel edits, with their ranges.
MATERIAL_FIELDS = {
    "glass": (("ior", "float", 0.1, 3.0), ("absorption_color", "color", 0.0, 1.0),
              ("absorption_distance", "float", 0.01, 100.0)),
    "mirror": (("color", "color", 0.0, 1.0),),
    "diffuse": (("color", "color", 0.0, 1.0),),
}

