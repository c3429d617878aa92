"""The layout's own rules: no import cycle in caustica (function-level imports included) and no texture unit
or binding point claimed twice (docs/architecture.md)."""
import ast
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "caustica"


def module_name(path: Path) -> str:
    parts = ("caustica",) + path.relative_to(PACKAGE).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(path: Path, modules: set[str]) -> set[str]:
    """The caustica modules a file imports anywhere in it (top level, functions, TYPE_CHECKING blocks aside)."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    tree = ast.parse(path.read_text(), str(path))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            node.body = []  # typing-only imports are not run
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                origin = ".".join(base + ([node.module] if node.module else []))
            else:
                origin = node.module or ""
            targets = [origin] + [f"{origin}.{alias.name}" for alias in node.names]
        else:
            continue
        found.update(t for t in targets if t in modules)
    # a package's own __init__ runs before its modules: importing it from inside is not a cycle
    return {t for t in found if not name.startswith(t + ".") and t != name}


def import_graph() -> dict[str, set[str]]:
    files = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    modules = set(files)
    return {name: imported_modules(path, modules) for name, path in files.items()}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in graph.get(node, ()):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_cycle_finder_sees_a_function_level_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(graph) == [["a", "b", "c"]]


def test_no_import_cycle():
    found = cycles(import_graph())
    assert not found, "import cycles: " + "; ".join(" <-> ".join(c) for c in found)


def test_no_texture_unit_or_binding_point_is_claimed_twice():
    """The shading programs' texture units (render/bindings.py) do not overlap, and stay under the 48 combined
    units every GL 3.3 context has; the storage binding points are distinct, and the shaders declare them: a
    shared include's at its table entry, every other shader's among DISPATCH_BINDINGS."""
    from caustica.render.bindings import DISPATCH_BINDINGS, STORAGE_BINDINGS, TEXTURE_UNITS

    claimed = [(unit, name) for name, units in TEXTURE_UNITS.items() for unit in units]
    units = [unit for unit, _ in claimed]
    assert len(units) == len(set(units)), sorted(claimed)
    assert min(units) == 0 and max(units) < 48
    shared = list(STORAGE_BINDINGS.values())
    assert len(set(shared)) == len(shared) and not set(shared) & set(DISPATCH_BINDINGS)
    declared = {}
    for path in (p for p in (PACKAGE / "shaders").rglob("*") if p.is_file()):
        for binding in re.findall(r"std430,\s*binding\s*=\s*(\d+)", path.read_text()):
            declared.setdefault(path.stem, set()).add(int(binding))
    assert declared.pop("fixed_point_flux") == {STORAGE_BINDINGS["fixed_point_flux"]}
    assert all(bindings <= set(DISPATCH_BINDINGS) for bindings in declared.values()), declared


def test_binders_take_their_units_from_the_table():
    """No module binds a shading texture to a unit of its own: outside render/bindings.py, a texture unit
    constant (a name ending in _UNIT) is not defined."""
    for path in PACKAGE.rglob("*.py"):
        if path.name == "bindings.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Assign):
                for target in node.targets:
                    names = [n.id for n in ast.walk(target) if isinstance(n, ast.Name)]
                    assert not any(n.endswith("_UNIT") for n in names), f"{path}: {names}"


LAYERS = [  # lowest first: a module imports from its own layer or the ones before it (docs/architecture.md)
    {"errors", "text", "progress", "cache", "atomic", "input_files", "images"},
    {"scene", "parameters"},
    {"raytrace", "per_vertex"},
    {"lighting", "transport", "metrics", "reference"},
    {"gpu"},
    {"render", "labels"},
    {"passes"},
    {"techniques", "planning"},
    {"renderer", "frame_limits", "cli", "batch", "bench", "viewer", "notebook", "__main__", "docs_techniques", ""},
]
# Presets that build their geometry with the per-vertex and ray solvers (a mirror fitted to a view), and the
# scene files' export, which writes Mitsuba XML too.
LAYER_EXCEPTIONS = {"caustica.scene.presets_per_vertex", "caustica.scene.io"}


def layer_of(module: str) -> int:
    top = module.split(".")[1] if "." in module else ""
    return next(i for i, names in enumerate(LAYERS) if top in names)


def test_layers_import_only_downwards():
    upward = sorted(f"{a} -> {b}" for a, targets in import_graph().items() for b in targets
                    if layer_of(b) > layer_of(a) and a not in LAYER_EXCEPTIONS)
    assert not upward, upward
