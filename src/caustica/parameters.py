"""Technique parameters declared once, as data.

Each field of a technique's ``Params`` dataclass is declared with :func:`param`: its default, its kind
(int, float, bool, choice, rgb, mapping), its range or choices, its unit, a one-line help and the paper
section it follows. From that one declaration come the validation (:class:`Params`' ``__post_init__``),
``caustica techniques --json`` and ``caustica techniques NAME``, the viewer's and the notebook's
controls (``viewer/params.py``) and ``docs/techniques.md`` (``caustica.docs_techniques``).

A class keeps an explicit ``__post_init__`` (calling ``super().__post_init__()`` first) only for rules
that tie fields together or that no range states (``directions`` = 2 r^2 + 1, ``photon_grid`` 0 taking
``map_size``).

Pure data, no GL: ``passes/`` (NearbyParams) and ``techniques/`` both declare with it.
"""
from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass
from typing import Any

from .errors import TechniqueError, short
from .scene import rules

KINDS = ("int", "float", "bool", "choice", "rgb", "mapping")
_ENDS = ("[]", "(]", "[)", "()")


@dataclass(frozen=True)
class Param:
    """What a parameter field is: kind, range (with its open or closed ``ends``) or choices, the values
    accepted outside the range with their meaning (``special``), unit, help, paper section, and a hint
    appended to the error message."""

    kind: str
    help: str
    range: tuple | None = None
    ends: str = "[]"
    choices: tuple = ()
    special: tuple = ()  # ((value, meaning), ...)
    unit: str = ""
    paper: str = ""
    hint: str = ""


def param(default, *, help: str, range: tuple | None = None, choices: tuple | None = None, ends: str = "[]",
          special: dict | None = None, unit: str = "", paper: str = "", hint: str = "", kind: str | None = None) -> Any:
    """A dataclass field with its declaration as metadata (``field.metadata['param']``).

    ``kind`` defaults to the default's type (a str with ``choices`` is a 'choice'); ``special`` maps values
    accepted outside the range to their meaning, e.g. ``{0: "= map_size"}`` or ``{None: "energy conserving"}``.
    A dict or list default is copied for each instance."""
    kind = kind or _kind_of(default, choices)
    info = Param(kind, help, tuple(range) if range is not None else None, ends, tuple(choices or ()),
                 tuple((special or {}).items()), unit, paper, hint)
    _check_declaration(info, default)
    if isinstance(default, (dict, list)):
        return dataclasses.field(default_factory=lambda: copy.deepcopy(default), metadata={"param": info})
    return dataclasses.field(default=default, metadata={"param": info})


def _kind_of(default, choices) -> str:
    if isinstance(default, bool):
        return "bool"
    if isinstance(default, int):
        return "int"
    if isinstance(default, float):
        return "float"
    if isinstance(default, str) and choices:
        return "choice"
    raise TypeError(f"param({default!r}): give kind= (one of {', '.join(KINDS)})")


def _check_declaration(info: Param, default) -> None:
    """A declaration must be complete: help, a range for numbers, choices for a choice."""
    if info.kind not in KINDS or not info.help or info.ends not in _ENDS:
        raise TypeError(f"param({default!r}): kind in {KINDS}, a help line and ends in {_ENDS} are required")
    if info.kind in ("int", "float", "rgb") and info.range is None:
        raise TypeError(f"param({default!r}): a {info.kind} needs range=(low, high)")
    if info.kind == "choice" and default not in info.choices:
        raise TypeError(f"param({default!r}): the default must be one of its choices {info.choices}")


def declared(params_class) -> list[tuple[dataclasses.Field, Param]]:
    """(field, declaration) of every declared field of ``params_class``, in field order."""
    return [(f, f.metadata["param"]) for f in dataclasses.fields(params_class) if "param" in f.metadata]


def default_of(field: dataclasses.Field):
    if field.default_factory is not dataclasses.MISSING:
        return field.default_factory()
    return None if field.default is dataclasses.MISSING else field.default


def _special(value, info: Param):
    """The special value ``value`` stands for (a tuple so that None can be one), or None."""
    for special, _ in info.special:
        if special is None and value is None:
            return (None,)
        if special is not None and not isinstance(value, bool) and rules.finite(value) and value == special:
            return (special,)
    return None


def check_value(name: str, value, info: Param, error=TechniqueError):
    """``value`` converted as ``info`` declares (int, float, bool, ...), or ``error`` naming ``name`` and
    what it must be."""
    found = _special(value, info)
    if found is not None:
        return found[0]
    low, high = info.range or (None, None)
    if info.kind == "int":
        try:
            return rules.integer(value, name, low, high, hint=info.hint, error=error)
        except error:
            alternatives = [f"{v} ({meaning})" for v, meaning in info.special if v is not None]
            if not alternatives:
                raise
            raise error(f"{name} {short(value)} must be {' or '.join(alternatives)} or an integer in "
                        f"[{low}, {high}]{info.hint}") from None
    if info.kind == "float":
        return rules.number(value, name, low, high, hint=info.hint, open_low=info.ends[0] == "(",
                            open_high=info.ends[1] == ")", error=error)
    if info.kind == "bool":
        return rules.flag(value, name, error=error)
    if info.kind == "choice":
        if not (isinstance(value, str) and value in info.choices):
            raise error(f"{name} {short(value)} must be one of {', '.join(info.choices)}{info.hint}")
        return value
    if info.kind == "rgb":  # three numbers (or one, grey), each in the range
        channels = rules.rgb(value, name, high, error=error)
        for x in channels:
            rules.number(x, f"{name} {short(value)}: channel", low, high, hint=info.hint, error=error)
        return tuple(float(x) for x in channels)
    return value  # 'mapping': its structure is the class's own rule


@dataclass
class Params:
    """Base of every technique's parameters: each declared field is checked against its declaration
    and stored converted (an int as int, 2.0 as 2)."""

    def __post_init__(self):
        for field, info in declared(type(self)):
            setattr(self, field.name, check_value(field.name, getattr(self, field.name), info))


def describe(params_class) -> list[dict]:
    """Every declared parameter of ``params_class`` as a JSON-ready dict: name, type, default, range
    (with ends) or choices, special values, unit, help, paper."""
    rows = []
    for field, info in declared(params_class):
        row = {"name": field.name, "type": info.kind, "default": default_of(field)}
        if info.range is not None:
            row["range"], row["ends"] = list(info.range), info.ends
        if info.choices:
            row["choices"] = list(info.choices)
        if info.special:
            row["special"] = [{"value": v, "means": meaning} for v, meaning in info.special]
        row.update(unit=info.unit, help=info.help, paper=info.paper)
        rows.append(row)
    return rows


def allowed_text(row: dict) -> str:
    """'[16, 8192]', 'one of a, b', with the special values: '0 (= map_size) or [8, 4096]'."""
    text = (f"{row['ends'][0]}{row['range'][0]:g}, {row['range'][1]:g}{row['ends'][1]}" if "range" in row
            else ", ".join(row.get("choices", ())) if row["type"] in ("choice", "mapping") else "true, false")
    specials = [f"{'none' if s['value'] is None else format(s['value'], 'g')} ({s['means']})" for s in row.get("special", ())]
    return " or ".join(specials + [text])
