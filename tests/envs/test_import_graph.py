"""The modules of ``relmogen/envs`` import one another one way: no circle, at start-up or lazily."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import relmogen.envs

PACKAGE = "relmogen.envs"
ENVS_DIR = Path(relmogen.envs.__file__).parent
MODULES = sorted(f"{PACKAGE}.{path.stem}" for path in ENVS_DIR.glob("*.py") if path.stem != "__init__")


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


def imported_modules(node: ast.Import | ast.ImportFrom, package_modules: set[str]) -> set[str]:
    """The modules of ``package_modules`` (or the package itself) that an import statement loads."""
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    else:
        base = node.module or ""
        names = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in package_modules else base
                 for alias in node.names]
    return {name for name in names if name in package_modules or name == PACKAGE}


def import_graph(sources: dict[str, str]) -> dict[str, set[str]]:
    """module -> the package modules it imports at run time, from each module's source."""
    modules = set(sources)
    return {module: {target for node in runtime_imports(ast.parse(source))
                     for target in imported_modules(node, modules)} - {module}
            for module, source in sources.items()}


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


def envs_sources() -> dict[str, str]:
    return {f"{PACKAGE}.{path.stem}": path.read_text() for path in ENVS_DIR.glob("*.py") if path.stem != "__init__"}


def test_the_static_import_graph_of_relmogen_envs_has_no_cycle():
    graph = import_graph(envs_sources())
    assert "relmogen.envs.controls" in graph["relmogen.envs.subgoal_controls"]  # the parse sees real imports
    assert "relmogen.envs.control_registry" in graph["relmogen.envs.relmogen_env"]
    assert find_cycle(graph) is None, f"import circle: {' -> '.join(find_cycle(graph))}"


def test_the_check_sees_lazy_imports_and_ignores_type_checking_ones():
    sources = {
        "relmogen.envs.a": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from relmogen.envs.b import B\n",
        "relmogen.envs.b": "def make():\n    from relmogen.envs import c\n",
        "relmogen.envs.c": "import relmogen.envs.b\n",
    }
    graph = import_graph(sources)
    assert graph["relmogen.envs.a"] == set()
    assert find_cycle(graph) == ["relmogen.envs.b", "relmogen.envs.c", "relmogen.envs.b"]


@pytest.mark.parametrize("module", MODULES)
def test_each_module_imports_first_in_a_fresh_interpreter(module):
    result = subprocess.run([sys.executable, "-c", f"import {module}"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
