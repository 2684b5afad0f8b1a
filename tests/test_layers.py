"""Layers that import downward only (issue 12): the import graph of `avionics`, `avionics_eval` and `avionics_sitl` has no
cycle, and no module imports a layer above its own.

Lowest first: `avionics.base` <- the output contract (`avionics.contract`) <- the stages (`avionics.tracking`, `avionics.conflict`, `avionics.advisory`) <-
configuration, composition and facade <- the flight shells and I/O <- `avionics_sitl` (may import `avionics`) <-
`avionics_eval` (demo, benches, reports: the only code that composes flight code and the simulator). Flight
code never imports the simulator.

The graph is read from the source with `ast`, not by importing: every `import` and `from ... import`, at module
level, inside functions and under `if TYPE_CHECKING:` alike, relative imports resolved. `from pkg import name`
is an edge to `pkg.name` when that is a module, else to `pkg`; every edge also reaches the packages above the
target (Python runs their `__init__` first), except those above the importer itself (already running).
A subprocess then checks at run time that importing the flight entry points loads no simulator module.
"""

from __future__ import annotations

import ast
import subprocess
import sys

import pytest

from tests.conftest import ROOT, SOURCES
PACKAGES = ("avionics", "avionics_eval", "avionics_sitl")

STAGES = ("avionics.tracking", "avionics.conflict", "avionics.advisory")
ABOVE_THE_STAGES = (  # the facade and what composes it, the shells, the I/O around the core
    "avionics.compose", "avionics.pipeline", "avionics.daa",
    "avionics.runner", "avionics.cli", "avionics.ports", "avionics.loop",
    "avionics.io", "avionics.monitor",
)
SHELLS = ("avionics.runner", "avionics.cli", "avionics.monitor")
# The core's jobs (avionics/pipeline/), in the order data flows through them: each imports none of those after it.
PIPELINE = tuple(f"avionics.pipeline.{m}" for m in (
    "records", "containment", "schedule", "intake", "assessment", "advice", "bands_traffic", "views", "daa_core"))
SIMULATOR = ("avionics_sitl", "avionics_eval")

# The layer rules, as data: (name, importers, kind, modules). An importer is every module named by, or inside, one
# of `importers`. kind "only": it may import nothing of the project outside `modules`; kind "not": it imports
# nothing named by, or inside, `modules`.
RULES = [
    ("the base imports nothing above it", ("avionics.base",), "only", ("avionics.base",)),
    # the output contract (issue 31): declarations over the base layer's types and units, read by stages, io and monitor
    ("the contract imports only the base", ("avionics.contract",), "only", ("avionics.base", "avionics.contract")),
    *((f"{stage} never imports the configuration module", (stage,), "not", ("avionics.config",))
      for stage in STAGES),
    *((f"{stage} never imports the facade, the shells, io or monitor", (stage,), "not", ABOVE_THE_STAGES + SIMULATOR)
      for stage in STAGES),
    ("tracking never imports conflict or advisory", ("avionics.tracking",), "not",
     ("avionics.conflict", "avionics.advisory")),
    ("conflict never imports advisory", ("avionics.conflict",), "not", ("avionics.advisory",)),
    ("io (adapters of core values) never imports the core's composition, the facade or the shells", ("avionics.io",),
     "not", ("avionics.config", "avionics.compose", "avionics.pipeline", "avionics.daa", "avionics.ports",
             "avionics.loop") + SHELLS),
    ("the composition root never imports the core or anything above it", ("avionics.compose",), "not",
     ("avionics.pipeline", "avionics.daa", "avionics.ports", "avionics.loop") + SHELLS),
    ("the core never imports the facade or anything above it", ("avionics.pipeline",), "not",
     ("avionics.daa", "avionics.ports", "avionics.loop") + SHELLS),
    *((f"{job} imports no job of the core after it", (job,), "not", PIPELINE[i + 1:])
      for i, job in enumerate(PIPELINE)),
    ("the facade never imports the ports, the loop or the shells", ("avionics.daa",), "not",
     ("avionics.ports", "avionics.loop") + SHELLS),
    ("ports and the loop never import the shells", ("avionics.ports", "avionics.loop"), "not", SHELLS),
    ("flight code never imports the simulator", ("avionics",), "not", SIMULATOR),
    ("avionics_sitl never imports avionics_eval", ("avionics_sitl",), "not", ("avionics_eval",)),
]

# What importing the flight entry points (`avionics run`, `avionics config/monitor/router`, the monitor) may load.
FLIGHT_ENTRY_POINTS = ("avionics.cli", "avionics.runner", "avionics.monitor.app")


def within(module: str, prefixes) -> bool:
    return any(module == p or module.startswith(p + ".") for p in prefixes)


def discover() -> dict[str, Path]:
    """Dotted module name -> source file, for every module of PACKAGES."""
    modules = {}
    for package in PACKAGES:
        for path in sorted((SOURCES[package] / package).rglob("*.py")):
            parts = path.relative_to(SOURCES[package]).with_suffix("").parts
            if "__pycache__" in parts:
                continue
            if parts[-1] == "__init__":
                parts = parts[:-1]
            modules[".".join(parts)] = path
    return modules


def imported_names(module: str, path: Path) -> list[tuple[str, int]]:
    """(dotted name, line) of everything the module imports, relative imports resolved; for `from X import a`,
    both `X` and `X.a` (the caller keeps whichever is a module)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    is_package = path.name == "__init__.py"
    names = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                anchor = module.split(".") if is_package else module.split(".")[:-1]
                if node.level - 1 > len(anchor) - 1:
                    raise AssertionError(f"{path}:{node.lineno}: relative import beyond the top-level package")
                anchor = anchor[:len(anchor) - (node.level - 1)]
                base = ".".join(anchor + ([node.module] if node.module else []))
            else:
                base = node.module
            names.append((base, node.lineno))
            names += [(f"{base}.{alias.name}", node.lineno) for alias in node.names if alias.name != "*"]
    return names


def ancestors(module: str) -> list[str]:
    parts = module.split(".")
    return [".".join(parts[:i]) for i in range(1, len(parts))]


def build_graph() -> tuple[dict[str, set[str]], dict[tuple[str, str], int]]:
    """module -> the project modules it imports; (importer, imported) -> a line where it does."""
    modules = discover()
    graph: dict[str, set[str]] = {m: set() for m in modules}
    lines: dict[tuple[str, str], int] = {}
    for module, path in modules.items():
        own_ancestors = set(ancestors(module))
        for name, line in imported_names(module, path):
            if name not in modules:
                continue  # outside the project, or `from pkg import a_function` (the `pkg` entry covers it)
            for target in (name, *ancestors(name)):
                if target != module and target not in own_ancestors and target in modules:
                    graph[module].add(target)
                    lines.setdefault((module, target), line)
    return graph, lines


GRAPH, LINES = build_graph()


def where(importer: str, imported: str) -> str:
    path = discover()[importer].relative_to(ROOT)  # sitl/avionics_sitl/..., eval/avionics_eval/...
    return f"{path}:{LINES[(importer, imported)]} {importer} -> {imported}"


def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One cycle (as a path that returns to its start) per strongly connected component that has one (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[set[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1 or v in graph[v]:
                components.append(component)

    for v in sorted(graph):
        if v not in index:
            connect(v)

    cycles = []
    for component in components:  # a shortest way back to its first module, inside the component (breadth first)
        start = min(component)
        previous: dict[str, str | None] = {start: None}
        queue = [start]
        last = None
        while last is None:
            v = queue.pop(0)
            if start in graph[v]:
                last = v
            for w in sorted(graph[v] & component):
                if w not in previous:
                    previous[w] = v
                    queue.append(w)
        path = []
        while last is not None:
            path.append(last)
            last = previous[last]
        cycles.append(path[::-1] + [start])
    return cycles


def test_the_graph_is_read_from_every_package():
    assert {"avionics.cli", "avionics.base.units", "avionics_eval.cli", "avionics_eval.reports.tracking",
            "avionics_sitl.encounters", "avionics_sitl.trajectory"} <= GRAPH.keys()
    assert "avionics.cli" in GRAPH["avionics_eval.cli"]
    assert "avionics_sitl.builtin" in GRAPH["avionics_sitl.encounters"]  # a module named by `from avionics_sitl.builtin import BUILTIN`
    assert "avionics.io" in GRAPH["avionics_sitl.autopilot"]  # `import avionics.io`


def test_every_job_of_the_core_is_a_module():
    """The rules of PIPELINE hold for modules that exist: a job renamed or moved fails here, not silently."""
    assert set(PIPELINE) <= GRAPH.keys()
    assert {m for m in GRAPH if m.startswith("avionics.pipeline.")} == set(PIPELINE)


def test_cycle_finder_reports_a_cycle():
    assert find_cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c", "a"]]
    assert find_cycles({"a": {"a"}}) == [["a", "a"]]
    assert find_cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle():
    cycles = find_cycles(GRAPH)
    assert not cycles, "import cycles:\n" + "\n".join(
        " -> ".join(cycle) + "\n    " + "\n    ".join(where(a, b) for a, b in zip(cycle, cycle[1:]))
        for cycle in cycles)


def violations(graph: dict[str, set[str]], importers, kind: str, modules) -> list[tuple[str, str]]:
    """(importer, imported) of every import the rule forbids."""
    return [(importer, imported) for importer in sorted(m for m in graph if within(m, importers))
            for imported in sorted(graph[importer]) if within(imported, modules) != (kind == "only")]


def test_rule_checker_reports_an_upward_import():
    graph = {"avionics.base.units": {"avionics.base.geodesy"}, "avionics.base.geodesy": {"avionics.config"},
             "avionics.config": set(), "avionics.tracking.imm": {"avionics.base.units", "avionics.io.link"},
             "avionics.io.link": set(), "avionics_evaluation": set(), "avionics.runner": {"avionics_evaluation"}}
    assert violations(graph, ("avionics.base",), "only", ("avionics.base",)) == [
        ("avionics.base.geodesy", "avionics.config")]
    assert violations(graph, ("avionics.tracking",), "not", ("avionics.io",)) == [
        ("avionics.tracking.imm", "avionics.io.link")]
    assert violations(graph, ("avionics",), "not", ("avionics_eval",)) == []  # a name prefix is not a package


@pytest.mark.parametrize("importers, kind, modules",
                         [pytest.param(importers, kind, modules, id=name) for name, importers, kind, modules in RULES])
def test_layer_rule(importers, kind, modules):
    found = violations(GRAPH, importers, kind, modules)
    assert not found, f"{len(found)} upward import(s):\n" + "\n".join(where(a, b) for a, b in found)


def test_flight_entry_points_load_no_simulator_module():
    code = ("import sys\n"
            f"import {', '.join(FLIGHT_ENTRY_POINTS)}\n"
            "print('\\n'.join(sorted(m for m in sys.modules if m.split('.')[0] in ('avionics_sitl', 'avionics_eval'))))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == [], f"importing {', '.join(FLIGHT_ENTRY_POINTS)} loaded:\n{proc.stdout}"
