"""The techniques and their parameters, from their declarations: ``caustica techniques --json`` and
``caustica techniques NAME`` print them, ``python -m caustica.docs_techniques [PATH]`` writes
``docs/techniques.md`` (tests/test_params.py checks that the file is current).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from .parameters import allowed_text, describe

DOCS_PATH = Path(__file__).resolve().parents[2] / "docs" / "techniques.md"
_COLUMNS = ("name", "type", "default", "allowed", "unit", "help", "paper")


def technique_info(name: str) -> dict:
    """One technique as data: name, summary, uses_gl, parameters (:func:`caustica.parameters.describe`);
    a ``view+caustics`` composite lists its two halves under ``parts``."""
    from .techniques import get_technique

    technique = get_technique(name)
    if hasattr(technique, "view") and hasattr(technique, "caustics"):
        return {"name": technique.name, "summary": technique.summary,
                "parts": [technique_info(technique.view.name), technique_info(technique.caustics.name)]}
    return {"name": technique.name, "summary": technique.summary, "uses_gl": technique.uses_gl,
            "parameters": describe(technique.Params)}


def catalogue() -> list[dict]:
    """Every registered technique, by name."""
    from .techniques import technique_names

    return [technique_info(name) for name in technique_names()]


def to_json(infos) -> str:
    return json.dumps(infos, indent=2)


def _cells(row: dict) -> dict:
    default = row["default"]
    text = "none" if default is None else str(default).lower() if isinstance(default, bool) else str(default)
    return {"name": row["name"], "type": row["type"], "default": text, "allowed": allowed_text(row),
            "unit": row["unit"], "help": row["help"], "paper": row["paper"]}


def table(info: dict) -> str:
    """A technique's parameters as an aligned text table (``caustica techniques NAME``)."""
    if "parts" in info:
        return "\n\n".join([f"{info['name']}: {info['summary']}"] + [table(part) for part in info["parts"]])
    rows = [_cells(row) for row in info["parameters"]]
    head = f"{info['name']}: {info['summary']}"
    if not rows:
        return f"{head}\n  (no parameters)"
    widths = {c: max(len(c), *(len(r[c]) for r in rows)) for c in _COLUMNS[:-2]}
    lines = [head, "  " + "  ".join(c.ljust(widths[c]) for c in _COLUMNS[:-2]) + "  help [paper]"]
    for r in rows:
        paper = f" [{r['paper']}]" if r["paper"] else ""
        lines.append("  " + "  ".join(r[c].ljust(widths[c]) for c in _COLUMNS[:-2]) + f"  {r['help']}{paper}")
    return "\n".join(lines)


def markdown() -> str:
    """docs/techniques.md: every technique with a table of its parameters."""
    out = ["# Techniques and their parameters", "",
           "Generated from the parameter declarations (`caustica.parameters.param`) by "
           "`python -m caustica.docs_techniques`; do not edit by hand. `caustica techniques --json` prints the "
           "same as data. A composite `view+caustics` takes both halves' parameters (`technique.name` where "
           "both have one of that name).", ""]
    for info in catalogue():
        out += [f"## `{info['name']}`", "", info["summary"], ""]
        if not info["parameters"]:
            out += ["No parameters.", ""]
            continue
        out += ["| " + " | ".join(_COLUMNS) + " |", "|" + "---|" * len(_COLUMNS)]
        for row in info["parameters"]:
            cells = _cells(row)
            out.append("| " + " | ".join(f"`{cells[c]}`" if c in ("name", "default") else
                                         cells[c].replace("|", "\\|") for c in _COLUMNS) + " |")
        out.append("")
    return "\n".join(out)


def write(path: Path = DOCS_PATH) -> Path:
    path.write_text(markdown(), encoding="utf-8")
    return path


if __name__ == "__main__":
    print(f"wrote {write(Path(sys.argv[1]) if len(sys.argv) > 1 else DOCS_PATH)}")
