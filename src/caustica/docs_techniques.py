"""The techniques and their parameters, from their declarations: ``caustica techniques --json`` and
``caustica techniques NAME`` print them, ``python -m caustica.docs_techniques [PATH]`` writes
``docs/techniques.md`` (tests/test_params.py checks that the file is current);
``python -m caustica.docs_techniques --which-technique [PATH]`` writes ``docs/which-technique.md`` from the
auto planner (tests/test_which_technique.py checks that one).
"""
from __future__ import annotations

import json
import re
import sys
from pathlib import Path

from .parameters import allowed_text, describe

DOCS_PATH = Path(__file__).resolve().parents[2] / "docs" / "techniques.md"
WHICH_PATH = DOCS_PATH.with_name("which-technique.md")
AUTO_DOCS = DOCS_PATH.with_name("auto.md")
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


def plan_rules(path: Path = AUTO_DOCS) -> list[tuple[str, str]]:
    """docs/auto.md's table of what auto picks per kind of scene, as (scene holds, technique) rows
    (tests/test_auto.py checks each row against :func:`caustica.plan`)."""
    text = path.read_text(encoding="utf-8")
    block = text[text.index("<!-- plan-rules -->"):text.index("<!-- /plan-rules -->")]
    rows = re.findall(r"^\| ([^|]+?) \| ([^|]+?) \|$", block, flags=re.M)
    return [(kind, technique) for kind, technique in rows if kind != "scene holds" and set(kind) != {"-"}]


def preset_plans() -> list[dict]:
    """Per built-in preset: its object and light counts and auto's plan."""
    from . import load_scene
    from .planning.rules import plan
    from .scene.presets import preset_names

    out = []
    for name in preset_names():
        scene = load_scene(name)
        kinds = [o.material.kind for o in scene.objects]
        out.append({"preset": name, "counts": {k: kinds.count(k) for k in ("glass", "mirror", "diffuse")},
                    "lights": len(scene.lights), "plan": plan(scene)})
    return out


def situation(chosen) -> str:
    """The kind of scene a plan's branch of the planner stands for, in words."""
    view, _, caustics = chosen.technique.partition("+")
    kinds = {entry.kind for entry in chosen.objects}
    words = {"depth-search": "Glass alone in the environment",
             "per-vertex": "Flat and convex mirrors, no glass",
             "env-map": "Nothing specular (glass of IOR 1 that absorbs nothing left out)"}.get(view)
    if view == "impostors":
        words = ("Glass near other geometry" + (" and mirrors" if "mirror" in kinds else "") if "glass" in kinds
                 else "A concave mirror, no glass")
    words = words or f"`{view}`"
    if caustics:
        words += {"caustic-mapping": ", under a light: caustics by caustic mapping",
                  "transport-table": ", under a light, solid glass not all convex whose light crosses it more "
                                     "than twice: caustics by the transport table's rays, traced"}.get(caustics, f", caustics by `{caustics}`")
    return words


def _markdown_text(text: str) -> str:
    """reStructuredText markup of a docstring as Markdown: ``x`` and :role:`x` become `x`."""
    return re.sub(r":\w+:`([^`]+)`", r"`\1`", text.replace("``", "`"))


def technique_limits(name: str) -> list[str]:
    """The paragraphs of a technique's module docstring that state its limits ("Limits", "Approximate"), a list
    that follows a paragraph ending in ':' included; [] where the module documents another technique."""
    from .techniques import get_technique

    doc = sys.modules[type(get_technique(name)).__module__].__doc__ or ""
    if not doc.startswith(f"``{name}``"):
        return []
    paragraphs, out = doc.strip().split("\n\n"), []
    for i, paragraph in enumerate(paragraphs):
        if re.search(r"^(Limits|Approximate)\b|\bLimits( \(the paper's\))?:", paragraph):
            out.append(" ".join(paragraph.split()))
            if paragraph.rstrip().endswith(":") and i + 1 < len(paragraphs):
                out.append(_doc_list(paragraphs[i + 1]))
    return [_markdown_text(p) for p in out]


def _doc_list(paragraph: str) -> str:
    """A docstring's bulleted paragraph as Markdown, one line per item."""
    items = re.split(r"^\s*- ", paragraph.strip(), flags=re.M)
    return "\n".join("- " + " ".join(item.split()) for item in items if item.strip())


def _technique_section(name: str) -> list[str]:
    from .techniques import get_technique

    lines = [f"### `{name}`", "", get_technique(name).summary + "."]
    limits = technique_limits(name)
    return lines + [""] + [part for p in limits for part in (p, "")] if limits else lines + [""]


def which_technique_markdown(plans: list[dict] | None = None) -> str:
    """docs/which-technique.md: what auto picks in each situation and why (its rules, and its plan of every
    preset), and each technique's strengths and limits from the registry."""
    from .planning import rules as auto_rules
    from .planning.rules import QUALITY
    from .techniques import technique_names

    plans = preset_plans() if plans is None else plans
    out = ["# Which technique when", "",
           "Generated from the `auto` planner (`caustica.plan`, src/caustica/planning/rules.py), docs/auto.md's "
           "table of its rules and the technique registry by `python -m caustica.docs_techniques "
           "--which-technique`; do not edit by hand (tests/test_which_technique.py checks that it is current). "
           "`caustica plan SCENE` prints the plan of any scene; docs/auto.md has the measurements behind the "
           "rules, and [the gallery](gallery.md) every preset rendered with `auto`, its frame time and its error "
           "against `exact`.", "",
           "## What auto picks", "",
           "docs/auto.md's table, which tests/test_auto.py checks against the planner on a scene of each kind:", "",
           "| scene holds | auto renders with |", "|---|---|"]
    out += [f"| {kind} | `{technique}` |" for kind, technique in plan_rules()]
    rules = next(p for p in (auto_rules.__doc__ or "").split("\n\n") if p.lstrip().startswith("- "))
    out += ["", "The planner's rules and their reasons, from its docstring:", "", _markdown_text(_doc_list(rules))]
    groups: dict[str, list] = {}
    for row in plans:
        groups.setdefault(situation(row["plan"]), []).append((row["preset"], row["plan"]))
    out += ["", "## Situations", "",
            "Each situation is a branch of the planner, with the built-in presets that take it (`caustica "
            "presets`). The reasons are the planner's own, from its plan of the first preset listed (the plans "
            "are made at quality `balanced`)."]
    for words, members in sorted(groups.items(), key=lambda item: item[1][0][1].technique):
        example_name, example = members[0]
        out += ["", f"### {words}", "", f"auto picks `{example.technique}`.", "",
                "Presets: " + ", ".join(f"`{name}`" for name, _ in members) + ".", "",
                f"Why, in the planner's words (`{example_name}`):", ""]
        seen = set()
        for entry in example.objects:
            if (entry.kind, entry.handled_by) not in seen:
                seen.add((entry.kind, entry.handled_by))
                out.append(f"- {entry.kind} (`{entry.object}`), by `{entry.handled_by}`: {entry.reason}")
        out += [f"- note: {note}" for note in example.notes]
    out += ["", "## Every preset", "",
            "| preset | glass | mirrors | diffuse | lights | auto picks |",
            "|---|---|---|---|---|---|"]
    for row in plans:
        counts = row["counts"]
        out.append(f"| `{row['preset']}` | {counts['glass']} | {counts['mirror']} | {counts['diffuse']} | "
                   f"{row['lights']} | `{row['plan'].technique}` |")
    out += ["", "## Quality", "", "`-p quality=` (or `--quality`) sets what the plan's cost depends on:", "",
            "| quality | internal bounces | impostor texels | caustic-map texels | shadow-map texels | "
            "transport-table photons |",
            "|---|---|---|---|---|---|"]
    out += [f"| {name} | " + " | ".join(map(str, values)) + " |" for name, values in QUALITY.items()]
    picked = sorted({part for row in plans for part in row["plan"].technique.split("+")}
                    | {part for _, technique in plan_rules() for part in technique.split("+")})
    out += ["", "## The techniques auto picks", "",
            "Each technique's summary (what it does) and the limits its module documents.", ""]
    for name in picked:
        out += _technique_section(name)
    out += ["## The other techniques", "", "Named with `--technique NAME` (`caustica techniques` lists them; "
            "`view+caustics` composes a view technique with a caustic one).", ""]
    for name in technique_names():
        if name not in picked and name != "auto":
            out += _technique_section(name)
    return "\n".join(out).rstrip() + "\n"


def write_which_technique(path: Path = WHICH_PATH) -> Path:
    path.write_text(which_technique_markdown(), encoding="utf-8")
    return path


USAGE = ("usage: python -m caustica.docs_techniques [PATH]   (writes docs/techniques.md, or PATH)\n"
         "       python -m caustica.docs_techniques --which-technique [PATH]   (writes docs/which-technique.md)")

if __name__ == "__main__":
    args = sys.argv[1:]
    if any(a.startswith("-") and a != "--which-technique" for a in args) or len(args) > 2:
        print(USAGE)
        sys.exit(0 if {"-h", "--help"} & set(args) else 2)
    if args[:1] == ["--which-technique"]:
        print(f"wrote {write_which_technique(Path(args[1]) if len(args) > 1 else WHICH_PATH)}")
    else:
        print(f"wrote {write(Path(args[0]) if args else DOCS_PATH)}")
