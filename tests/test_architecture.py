"""The layout is the architecture: checks on the import graph and the size of functions.

- no import cycle inside ``ftc_mj`` (every ``import``/``from … import`` counts, also the lazy ones
  inside functions and under ``TYPE_CHECKING``: a cycle of lazy imports is still a cycle of concepts);
- the packages are layered (:data:`LAYERS`): no package imports a package of a higher layer, and the
  file graph collapsed to packages has no cycle (two packages of one layer may import each other's
  modules in one direction only);
- the components (``estimation``, ``control``, ``plant``, ``reconfiguration``) are built from their
  own settings: none of their modules imports the application config ``ftc_mj.config`` or the wiring
  ``ftc_mj.wiring`` (the one layer that reads the config and builds them);
- no function longer than 80 lines outside generated code.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import ftc_mj

ROOT = Path(ftc_mj.__file__).parent
COMPONENT_PACKAGES = ("estimation", "control", "plant", "reconfiguration")
LAYERS: tuple[tuple[str, ...], ...] = (
    # the base modules: errors, the typed settings fields and their validation, the registry, file
    # helpers, the run context a component may know, the Markdown table helper, the lazy-import helper, the disk cache;
    # ``ftc_mj`` is the lazy facade ``ftc_mj/__init__.py`` (its static imports are base ones, the rest are
    # importlib strings)
    ("ftc_mj", "errors", "validation", "suggest", "resources", "registry", "io", "context", "fields", "markdown",
     "lazy", "disk_cache"),
    ("model",),                                     # the kinematics and the sensor model, one definition
    ("plant", "estimation", "control"),             # the components, built from their own settings
    ("telemetry",),                                 # the trace columns and events the components write
    ("reconfiguration",),                           # the policies between the estimators and the controllers
    ("config",),                                    # the application config, composing the components' settings
    ("wiring",),                                    # builds components from the config (the factories' layer)
    ("identity", "metrics"),                        # a run's identity; the metrics of a run
    ("rundir",),                                    # the reader of a run folder
    ("rerun",),                                     # Rerun recordings and comparisons of run folders
    ("sim",),                                       # the closed loop and a run
    ("study",),                                     # sweeps of runs
    ("paper", "benchmark"),                         # the experiments built on studies
    ("reports",),                                   # docs/ pages from the studies, the paper and the benchmark
    ("api", "envs"),                                # the Python API; the Gymnasium environment
    ("cli",),                                       # the command line
)
"""The layer order of the top-level packages and modules of ``ftc_mj``, lowest first."""
MAX_FUNCTION_LINES = 80
GENERATED_MARKER = "GENERATED"


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _resolve(path: Path, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    package = module_name(path).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    base = package[: len(package) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imported_modules(path: Path) -> set[str]:
    """Every ``ftc_mj`` module ``path`` imports (a ``from pkg import name`` names ``pkg.name`` too)."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            target = _resolve(path, node)
            out.add(target)
            out.update(f"{target}.{a.name}" for a in node.names)
    return {m for m in out if m == "ftc_mj" or m.startswith("ftc_mj.")}


def import_graph() -> dict[str, set[str]]:
    files = {module_name(p): p for p in ROOT.rglob("*.py")}
    return {m: {d for d in imported_modules(p) if d in files and d != m} for m, p in files.items()}


def find_cycle(graph: dict[str, set[str]]) -> list[str]:
    """One cycle of ``graph`` (a list of modules, first = last) or ``[]`` (iterative DFS)."""
    state: dict[str, int] = {}
    for root in sorted(graph):
        if root in state:
            continue
        stack = [(root, iter(sorted(graph[root])))]
        path = [root]
        state[root] = 1
        while stack:
            node, children = stack[-1]
            child = next(children, None)
            if child is None:
                stack.pop()
                path.pop()
                state[node] = 2
            elif state.get(child) == 1:
                return path[path.index(child):] + [child]
            elif child not in state:
                state[child] = 1
                path.append(child)
                stack.append((child, iter(sorted(graph[child]))))
    return []


def package_of(module: str) -> str:
    """The top-level package (or module) of ``ftc_mj`` that ``module`` belongs to (``ftc_mj`` for the root)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def package_graph(graph: dict[str, set[str]]) -> dict[str, dict[str, str]]:
    """The module graph collapsed to packages: ``{package: {imported package: one module-level import that
    makes the edge}}`` (imports inside a package left out)."""
    out: dict[str, dict[str, str]] = {}
    for module in sorted(graph):
        edges = out.setdefault(package_of(module), {})
        for target in sorted(graph[module]):
            if package_of(target) != package_of(module):
                edges.setdefault(package_of(target), f"{module} -> {target}")
    return out


def layer_violations(packages: dict[str, dict[str, str]], layers: tuple[tuple[str, ...], ...]) -> list[str]:
    """Every import of a package from a higher layer (as ``module -> module``, with the two layers)."""
    level = {p: i for i, layer in enumerate(layers) for p in layer}
    return [f"{why} (layer {level[p]} imports layer {level[q]})" for p, edges in sorted(packages.items())
            for q, why in sorted(edges.items()) if level[q] > level[p]]


def test_every_package_has_a_layer():
    declared = [p for layer in LAYERS for p in layer]
    assert len(declared) == len(set(declared)), "a package is declared in two layers"
    found = set(package_graph(import_graph()))
    assert not found - set(declared), f"packages without a layer in LAYERS: {sorted(found - set(declared))}"
    assert not set(declared) - found, f"LAYERS names missing packages: {sorted(set(declared) - found)}"


def test_no_package_imports_a_higher_layer():
    wrong = layer_violations(package_graph(import_graph()), LAYERS)
    assert not wrong, "imports of a higher layer: " + "; ".join(wrong)


def test_no_package_level_import_cycle():
    packages = package_graph(import_graph())
    cycle = find_cycle({p: set(edges) for p, edges in packages.items()})
    assert not cycle, "package-level import cycle: " + " -> ".join(cycle) + " (" + "; ".join(
        packages[a][b] for a, b in zip(cycle, cycle[1:], strict=False)) + ")"


def test_the_package_checks_find_planted_faults():
    graph = {"ftc_mj.study.a": {"ftc_mj.paper.b"}, "ftc_mj.paper.b": {"ftc_mj.study.c"}, "ftc_mj.study.c": set(),
             "ftc_mj.control.factory": {"ftc_mj.config.x"}, "ftc_mj.config.x": set()}
    packages = package_graph(graph)
    assert packages["study"] == {"paper": "ftc_mj.study.a -> ftc_mj.paper.b"}
    assert packages["control"] == {"config": "ftc_mj.control.factory -> ftc_mj.config.x"}, "no module is exempt"
    assert find_cycle({p: set(e) for p, e in packages.items()}) == ["paper", "study", "paper"]
    assert layer_violations(packages, (("control",), ("config",), ("study",), ("paper",))) == [
        "ftc_mj.control.factory -> ftc_mj.config.x (layer 0 imports layer 1)",
        "ftc_mj.study.a -> ftc_mj.paper.b (layer 2 imports layer 3)"]


def test_no_import_cycle_inside_ftc_mj():
    cycle = find_cycle(import_graph())
    assert not cycle, "import cycle: " + " -> ".join(cycle)


def test_find_cycle_finds_a_planted_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) == []


@pytest.mark.parametrize("package", COMPONENT_PACKAGES)
def test_components_do_not_read_the_application_config(package):
    """No module of a component package imports the application config or the wiring above it (lazy imports
    included): a component receives its own settings model and the run context."""
    folder = ROOT / package
    assert folder.is_dir(), f"ftc_mj/{package} is missing"
    above = ("ftc_mj.config", "ftc_mj.wiring")
    offenders = [str(p.relative_to(ROOT)) for p in sorted(folder.rglob("*.py"))
                 if any(m == a or m.startswith(a + ".") for m in imported_modules(p) for a in above)]
    assert not offenders, f"a component imports ftc_mj.config or ftc_mj.wiring: {offenders}"


def long_functions(path: Path) -> list[str]:
    text = path.read_text()
    lines = text.splitlines()
    out = []
    for node in ast.walk(ast.parse(text, str(path))):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            body = lines[node.lineno - 1: node.end_lineno]
            if any(GENERATED_MARKER in ln for ln in body):
                continue
            n = node.end_lineno - node.lineno + 1
            if n > MAX_FUNCTION_LINES:
                out.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({n} lines)")
    return out


def test_functions_fit_on_a_screen():
    too_long = [f for p in sorted(ROOT.rglob("*.py")) for f in long_functions(p)]
    assert not too_long, f"functions longer than {MAX_FUNCTION_LINES} lines: {too_long}"


def test_the_checks_see_the_package():
    graph = import_graph()
    assert "ftc_mj.sim.loop" in graph and graph["ftc_mj.sim.loop"], "the import graph is empty"
