"""Parameter controls built from a technique's ``Params`` dataclass, with no per-technique code.

Each field becomes a :class:`ParamSpec`: bool -> checkbox, int/float -> a drag
with a range, a choice -> a combo. Ranges and choices come from the field's
declaration (:func:`caustica.parameters.param`), the same one that validates it,
so the panel always offers what the technique accepts.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..parameters import declared, default_of


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
    return [_spec(field, info) for field, info in declared(technique.Params) if not field.name.startswith("_")]


def _spec(field, info) -> ParamSpec:
    """A control from the field's declaration: a drag over its range (down to a special value such as 0
    meaning "automatic"), a combo of its choices, a checkbox; None defaults and mappings are 'other'."""
    default = default_of(field)
    if info.kind == "bool":
        return ParamSpec(field.name, "bool", default)
    if info.kind == "choice":
        return ParamSpec(field.name, "choice", default, choices=info.choices)
    if info.kind in ("int", "float") and default is not None:
        low, high = info.range
        specials = [v for v, _ in info.special if v is not None]
        return ParamSpec(field.name, info.kind, default, min([low, *specials]), high)
    return ParamSpec(field.name, "other", default)


# Scene materials and lights: the fields a panel edits, with their ranges.
MATERIAL_FIELDS = {
    "glass": (("ior", "float", 0.1, 3.0), ("absorption_color", "color", 0.0, 1.0),
              ("absorption_distance", "float", 0.01, 100.0)),
    "mirror": (("color", "color", 0.0, 1.0),),
    "diffuse": (("color", "color", 0.0, 1.0),),
}

