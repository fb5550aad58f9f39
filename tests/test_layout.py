"""The package reads as its pipeline: each stage imports only earlier ones, and no import
cycle exists, counting imports inside functions."""

from __future__ import annotations

import ast
from pathlib import Path

import coverplan

PACKAGE = Path(coverplan.__file__).parent

# Earlier first. A module may import its own layer and the ones before it.
LAYERS = [
    {"errors", "progress", "files", "runs"},
    {"geometry"},
    {"equipment"},
    {"world"},
    {"shots"},
    {"flight"},
    {"planning", "evaluation", "voxel"},
    {"io"},
    {"sfm"},
    {"report"},
    {"job"},
    {"batch"},
    {"cli"},
]
RANK = {name: k for k, layer in enumerate(LAYERS) for name in layer}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in PACKAGE.rglob("*.py")}


def _imports(name: str, path: Path, modules) -> set[str]:
    """coverplan modules ``name`` imports anywhere in its file (functions included)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name in modules}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                if sub in modules:
                    found.add(sub)
                elif target in modules:
                    found.add(target)
    return found - {name}


def _graph():
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def _stage(module: str) -> str:
    return module.split(".")[1] if "." in module else ""


def test_every_module_belongs_to_a_stage():
    strays = sorted(m for m in _modules() if m != "coverplan" and _stage(m) not in RANK)
    assert not strays, f"modules outside the layers of this test: {strays}"


def test_each_stage_imports_only_earlier_ones():
    wrong = []
    for module, deps in _graph().items():
        if module == "coverplan":  # the facade re-exports from every stage
            continue
        for dep in deps:
            if dep == "coverplan":
                if RANK[_stage(module)] < RANK["job"]:
                    wrong.append(f"{module} imports the facade")
            elif RANK[_stage(dep)] > RANK[_stage(module)]:
                wrong.append(f"{module} -> {dep}")
    assert not wrong, "\n".join(sorted(wrong))


def test_no_import_cycles():
    graph = _graph()
    state: dict[str, int] = {}
    cycles = []

    def visit(node, path):
        state[node] = 1
        for dep in sorted(graph.get(node, ())):
            if state.get(dep) == 1:
                cycles.append(" -> ".join(path[path.index(dep):] + [dep]))
            elif dep not in state:
                visit(dep, path + [dep])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    assert not cycles, "\n".join(cycles)


MAX_LINES = 500  # one concern per module; past this it holds two


def test_no_module_is_over_500_lines():
    long = {name: n for name, path in _modules().items()
            if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not long, long


def test_the_layer_check_sees_a_cycle(tmp_path, monkeypatch):
    """The cycle finder is not blind: two modules importing each other are reported."""
    import tests.test_layout as layout
    fake = {"coverplan.a": {"coverplan.b"}, "coverplan.b": {"coverplan.a"}}
    monkeypatch.setattr(layout, "_graph", lambda: fake)
    try:
        layout.test_no_import_cycles()
    except AssertionError as exc:
        assert "coverplan.a -> coverplan.b -> coverplan.a" in str(exc)
    else:
        raise AssertionError("a cycle went unseen")


def test_the_facade():
    for name in ("plan", "evaluate", "simulate", "load_scene", "Route", "get_camera", "PlanSettings"):
        assert hasattr(coverplan, name), name
