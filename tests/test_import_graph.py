"""The package imports downward: each module imports only from its own floor or lower ones, and no
modules import one another in a circle. Imports inside functions count (a lazy import is still an
arrow); ``if TYPE_CHECKING:`` ones do not."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import relmogen

PACKAGE_DIR = Path(relmogen.__file__).parent
# Lowest first, as README's Layout lists them: a module may import its own floor and those below.
# The package itself (relmogen/__init__.py: relmogen.load) and the command line are the top floor.
FLOORS = ["simulation", "robots", "scenes", "tasks", "motion_generation", "envs", "agents", "experiments",
          "visualisation", "bench", "analysis", "relmogen"]
TOP_LEVEL_MODULES = {"relmogen", "relmogen.cli", "relmogen.__main__"}


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE_DIR.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def package_sources() -> dict[str, tuple[str, bool]]:
    """module -> (its source, whether it is a package's ``__init__``)."""
    return {module_name(path): (path.read_text(), path.name == "__init__.py") for path in PACKAGE_DIR.rglob("*.py")}


def is_type_checking_block(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)


def runtime_imports(tree: ast.AST) -> list[ast.Import | ast.ImportFrom]:
    """Every import statement that can run: at module level or inside a function, not under
    ``if TYPE_CHECKING:``."""
    found, pending = [], [tree]
    while pending:
        node = pending.pop()
        if is_type_checking_block(node):
            pending.extend(node.orelse)
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            found.append(node)
        pending.extend(ast.iter_child_nodes(node))
    return found


def absolute_base(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    """The module a ``from ... import`` reads from, with relative imports resolved."""
    if not node.level:
        return node.module or ""
    parts = module.split(".") if is_package else module.split(".")[:-1]
    parts = parts[:len(parts) - (node.level - 1)]
    return ".".join(parts + ([node.module] if node.module else []))


def imported_modules(node: ast.Import | ast.ImportFrom, module: str, is_package: bool, known: set[str]) -> set[str]:
    """The package's modules an import statement loads (``from a import b`` loads ``a.b`` when that
    is a module, else ``a``)."""
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    else:
        base = absolute_base(node, module, is_package)
        names = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base for alias in node.names]
    return {name for name in names if name in known}


def import_graph(sources: dict[str, tuple[str, bool]]) -> dict[str, set[str]]:
    """module -> the package modules it imports at run time, from each module's source."""
    known = set(sources)
    return {module: {target for node in runtime_imports(ast.parse(source))
                     for target in imported_modules(node, module, is_package, known)} - {module}
            for module, (source, is_package) in sources.items()}


def floor_of(module: str) -> int | None:
    """The index in ``FLOORS`` of a module's floor; None for modules outside them (data folders)."""
    if module in TOP_LEVEL_MODULES:
        return FLOORS.index("relmogen")
    folder = module.split(".")[1]
    return FLOORS.index(folder) if folder in FLOORS else None


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    """Each import of a module on a higher floor, as ``importer -> imported``."""
    return sorted(f"{module} -> {target}" for module, targets in graph.items() for target in targets
                  if None not in (floor_of(module), floor_of(target)) and floor_of(target) > floor_of(module))


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import circle as a list of modules (first == last), or None."""
    state: dict[str, str] = {}

    def visit(module: str, path: list[str]) -> list[str] | None:
        state[module] = "open"
        for target in sorted(graph.get(module, ())):
            if state.get(target) == "open":
                return path[path.index(target):] + [target]
            if target not in state and (cycle := visit(target, [*path, target])):
                return cycle
        state[module] = "done"
        return None

    for module in sorted(graph):
        if module not in state and (cycle := visit(module, [module])):
            return cycle
    return None


def test_every_module_is_on_a_floor_or_holds_no_code():
    sources = package_sources()
    assert {module.split(".")[1] for module in sources if floor_of(module) is None} == set()


def test_no_module_imports_from_a_higher_floor():
    graph = import_graph(package_sources())
    assert "relmogen.motion_generation.arm" in graph["relmogen.motion_generation.reachability"]  # real imports
    assert "relmogen.experiments.evaluate" in graph["relmogen.experiments.monitor"]  # lazy ones too
    assert upward_imports(graph) == []


def test_no_modules_import_one_another_in_a_circle():
    graph = import_graph(package_sources())
    cycle = find_cycle(graph)
    assert cycle is None, f"import circle: {' -> '.join(cycle)}"


def test_the_check_sees_lazy_and_relative_imports_and_ignores_type_checking_ones():
    sources = {
        "relmogen.envs.a": ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from relmogen.envs.b import B\n",
                            False),
        "relmogen.envs.b": ("def make():\n    from relmogen.envs import c\n", False),
        "relmogen.envs.c": ("from . import b\nfrom ..experiments.train import train\n", False),
        "relmogen.experiments.train": ("", False),
        "relmogen.envs": ("", True),
    }
    graph = import_graph(sources)
    assert graph["relmogen.envs.a"] == set()
    assert graph["relmogen.envs.c"] == {"relmogen.envs.b", "relmogen.experiments.train"}
    assert find_cycle(graph) == ["relmogen.envs.b", "relmogen.envs.c", "relmogen.envs.b"]
    assert upward_imports(graph) == ["relmogen.envs.c -> relmogen.experiments.train"]


ENVS_MODULES = sorted(module for module in package_sources() if module.startswith("relmogen.envs."))


@pytest.mark.parametrize("module", ENVS_MODULES)
def test_each_envs_module_imports_first_in_a_fresh_interpreter(module):
    result = subprocess.run([sys.executable, "-c", f"import {module}"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
