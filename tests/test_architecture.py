"""The import graph of app/: no cycles, and no import against the stage order.

Stages, in the direction of flow (README, Layout): mesh -> discretisation -> assembly ->
contact -> condensation -> lcp -> interface -> output, with the foundations below them
(errors, typed config, closed forms, PETSc library, MPI helpers) and the driver layers above:
the run's phases (app/driver/) -> one run (app/run.py) -> a command's start and its
failures (app/startup/) -> studies of many runs (app/studies/) -> the command line
(app/cli.py, app/__main__.py). A module may import its own layer and the layers below it.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

APP = Path(__file__).resolve().parents[1] / "app"

FOUNDATIONS = ("errors", "config", "config_keys", "scene", "closed_form", "references",
               "petsc_lib", "parallel", "exit_sync", "expressions", "petsc_options", "hard_stop",
               "petsc_config_guard", "user_paths", "plotting", "blas_threads")
STAGES = ("mesh", "discretisation", "assembly", "contact", "condensation", "lcp",
          "interface", "output")
DRIVER = ("driver", "run", "startup", "studies", "cli", "__main__")
NUMPY_ONLY = ("discretisation", "contact", "lcp")  # kernels testable without MPI or files


def _module_name(path: Path) -> str:
    rel = path.relative_to(APP.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(path: Path) -> set[str]:
    """Every module this file imports (absolute names), including imports in functions."""
    tree = ast.parse(path.read_text())
    package = _module_name(path).rsplit(".", 1)[0] if path.name != "__init__.py" else \
        _module_name(path)
    out = set()
    for node in _runtime_nodes(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1]
                                + ([base] if base else []))
            out.add(base)
            out.update(f"{base}.{a.name}" for a in node.names)
    return out


def _runtime_nodes(tree: ast.AST):
    """Every node except those under `if TYPE_CHECKING:` (annotations only, no import)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and getattr(child.test, "id", "") == "TYPE_CHECKING":
                stack.extend(child.orelse)
                continue
            stack.append(child)


def _graph() -> dict[str, set[str]]:
    files = {_module_name(p): p for p in APP.rglob("*.py")}
    graph = {}
    for name, path in files.items():
        graph[name] = {m for m in _imports(path) if m in files and m != name}
    return graph


def _rank(module: str) -> int:
    """0 foundations, 1.. the stages in order, then the driver layers in order; a module
    in none of them ranks with the command line (test_every_module_has_a_layer names it)."""
    if module == "app":
        return 0  # the package itself: its version
    layer = module.split(".")[1]
    if layer in FOUNDATIONS:
        return 0
    if layer in STAGES:
        return 1 + STAGES.index(layer)
    return 1 + len(STAGES) + (DRIVER.index(layer) if layer in DRIVER else len(DRIVER) - 1)


def test_every_module_has_a_layer():
    """app/ holds the foundations and one folder or module per stage and driver layer:
    a new top-level module is placed in its stage's folder or named here."""
    known = {*FOUNDATIONS, *STAGES, *DRIVER, "__init__"}
    stray = sorted({m.split(".")[1] for m in _graph() if m != "app"} - known)
    assert not stray, f"app/ modules in no layer (README, Layout): {', '.join(stray)}"


def test_no_import_against_the_stage_order():
    bad = [f"{a} -> {b}" for a, deps in _graph().items() for b in deps
           if _rank(b) > _rank(a) and not b.startswith(a + ".")]
    assert not bad, "imports against the flow: " + ", ".join(sorted(bad))


def test_no_import_cycle():
    graph = _graph()
    state: dict[str, int] = {}
    cycles = []

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for dep in sorted(graph[node]):
            if dep.startswith(node + "."):
                continue  # a package importing its own submodule
            if state.get(dep) == 1:
                cycles.append(" -> ".join(path[path.index(dep):] + [dep]))
            elif dep not in state:
                visit(dep, path + [dep])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    assert not cycles, "import cycles: " + "; ".join(cycles)


@pytest.mark.parametrize("stage", NUMPY_ONLY)
def test_kernel_stages_need_no_petsc_or_mpi(stage):
    heavy = ("petsc4py", "mpi4py", "h5py")
    bad = [f"{p.relative_to(APP)} imports {m}" for p in (APP / stage).rglob("*.py")
           for m in _imports(p) if m.split(".")[0] in heavy]
    assert not bad, "; ".join(bad)


def test_the_checker_sees_violations(tmp_path):
    """The rank function orders stages as the README does (a guard on the test itself)."""
    assert _rank("app.config") < _rank("app.mesh.model") < _rank("app.lcp.lemke") \
        < _rank("app.output.xdmf") < _rank("app.run")
    assert _rank("app.interface.steps") > _rank("app.condensation.compliance")
    assert _rank("app.output.status") < _rank("app.driver.model") < _rank("app.run") \
        < _rank("app.startup.petsc") < _rank("app.studies.convergence") < _rank("app.cli")
    assert _rank("app.studies.level_mesh") == _rank("app.studies.sweep")
