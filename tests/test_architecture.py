"""The house rules of docs/architecture.md, read off the source: no import circles, the library
never imports a command, and no module or function grows past what a reader takes in at once."""

import ast
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 80
# The thin ``python -m cabinbench.X`` entries: the one place outside commands/ that may import a command.
ENTRY_MODULES = {
    f"cabinbench.{name}"
    for name in ("run", "train", "bench", "suites", "complexity", "building_maps", "__main__")
} | {f"cabinbench.{package}.__main__" for package in ("layouts", "leaderboard", "paper")}


def module_files() -> dict[str, Path]:
    """Every module of the installed package: cabinbench/, and baselines/ as cabinbench.baselines."""
    found = {}
    for folder, prefix in (
        (ROOT / "cabinbench", ["cabinbench"]),
        (ROOT / "baselines", ["cabinbench", "baselines"]),
    ):
        for path in sorted(folder.rglob("*.py")):
            parts = [*prefix, *path.relative_to(folder).with_suffix("").parts]
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


@cache
def import_graph() -> dict[str, set[str]]:
    """Module -> the package modules it imports (at any depth of its code)."""
    modules = module_files()
    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        targets = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(
                        [*package.split(".")[: len(package.split(".")) - node.level + 1], base]
                    ).strip(".")
                targets.add(base)
                targets.update(f"{base}.{alias.name}" for alias in node.names)
        imported = set()
        for target in targets:
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if target and target != name:
                imported.add(target)
        graph[name] = imported
    return graph


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's components, iteratively."""
    index, low, on_stack, stack, components = {}, {}, set(), [], []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                components.append(component)
    return components


def test_no_import_circles():
    circles = [sorted(c) for c in strongly_connected(import_graph()) if len(c) > 1]
    assert circles == []


def test_the_library_never_imports_a_command():
    offenders = {
        module: sorted(target for target in targets if target.startswith("cabinbench.commands"))
        for module, targets in import_graph().items()
        if not module.startswith("cabinbench.commands") and module not in ENTRY_MODULES
    }
    assert {module: targets for module, targets in offenders.items() if targets} == {}


@pytest.mark.parametrize("module", sorted(module_files()))
def test_modules_and_functions_stay_readable(module):
    path = module_files()[module]
    text = path.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= MAX_MODULE_LINES, f"{path} is over {MAX_MODULE_LINES} lines: split it"
    long = [
        f"{node.name} ({node.end_lineno - node.lineno + 1} lines)"
        for node in ast.walk(ast.parse(text))
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES
    ]
    assert long == [], f"{path}: functions over {MAX_FUNCTION_LINES} lines"


def test_no_symbolic_links_in_the_package():
    assert [path for path in (ROOT / "cabinbench").rglob("*") if path.is_symlink()] == []
