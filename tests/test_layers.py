"""The layers of the project, read from the source (every import statement, lazy ones in functions
included; nothing is imported here):

* no import cycles among the modules of ``clumpprops`` and ``studies``;
* the geometry math knows nothing of engines (no ``clumpprops.yade``, ``clumpprops.io``, YADE);
* ``clumpprops`` knows nothing of the studies, and the YADE script nothing of the driver;
* the reports and plots read results files: nothing they import, directly or through other
  modules, runs a simulation (``studies.runner``, ``studies.engine``, ``studies.hard_sphere_md``,
  Dask, YADE).
"""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("clumpprops", "studies")


def _modules():
    out = {}
    for pkg in PACKAGES:
        for f in sorted((ROOT / pkg).rglob("*.py")):
            parts = f.relative_to(ROOT).with_suffix("").parts
            out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = f
    return out


MODULES = _modules()


def _imports(name, path):
    """(project modules, top-level names of other modules) that module ``name`` imports."""
    pkg = name if path.name == "__init__.py" else name.rpartition(".")[0]
    ours, other = set(), set()

    def add(mod):
        if mod.split(".")[0] not in PACKAGES:
            other.add(mod.split(".")[0])
            return
        if mod not in MODULES:
            mod = mod.rpartition(".")[0] if mod.rpartition(".")[0] in MODULES else mod
        ours.add(mod)
        # importing p.q.r runs p/__init__ and p/q/__init__ first, unless the importer is inside them
        parts = mod.split(".")
        for k in range(1, len(parts)):
            parent = ".".join(parts[:k])
            if parent in MODULES and not (name == parent or name.startswith(parent + ".")):
                ours.add(parent)

    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            for a in node.names:
                add(a.name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = ".".join(pkg.split(".")[:len(pkg.split(".")) - node.level + 1])
                mod = f"{base}.{node.module}" if node.module else base
            else:
                mod = node.module
            for a in node.names:
                add(f"{mod}.{a.name}" if f"{mod}.{a.name}" in MODULES else mod)
    return ours, other


GRAPH = {m: _imports(m, p) for m, p in MODULES.items()}


def _closure(mod):
    seen, todo = set(), [mod]
    while todo:
        m = todo.pop()
        for d in GRAPH[m][0]:
            if d not in seen:
                seen.add(d)
                todo.append(d)
    return seen


def _loads(mod):
    """Every project module that `import mod` runs: its packages' __init__ files first, then what
    each of them imports, transitively (the cycle check leaves a module's own packages out)."""
    parts = mod.split(".")
    starts = [".".join(parts[:k]) for k in range(1, len(parts) + 1)]
    out = set(starts)
    for m in starts:
        out |= _closure(m)
    return out - {mod}


def test_the_graph_is_read():
    # the reader sees what is there (a reader that sees nothing would pass every rule below)
    assert {"clumpprops.api", "clumpprops.yade", "studies.report", "studies.runner"} <= set(MODULES)
    assert "studies.reduce" in GRAPH["studies.runner"][0] and "clumpprops.core" in GRAPH["clumpprops.yade.correction"][0]
    assert "studies.engine" in GRAPH["studies.__main__"][0]                 # a lazy import, in a function
    assert "clumpprops.io" in GRAPH["clumpprops.cli"][0]                     # ... and io/__init__, run first
    assert "studies" not in GRAPH["studies.runner"][0]                      # its own package: already run
    assert {"studies", "studies.design"} <= _loads("studies.report")         # ... but it runs first
    assert "distributed" in set().union(*(GRAPH[m][1] for m in _closure("studies.__main__")))


def test_no_import_cycles():
    cycles = [m for m in MODULES if m in _closure(m)]
    assert not cycles, f"modules on an import cycle: {cycles}"


def test_the_geometry_knows_nothing_of_engines_or_studies():
    engines = {m for m in MODULES if m.startswith(("clumpprops.yade", "clumpprops.io"))}
    # the command lines read and write files: they sit on top of both
    commands = {"clumpprops.cli", "clumpprops.__main__", "clumpprops.audit.cli", "clumpprops.show", "clumpprops.fit"}
    geometry = {m for m in MODULES if m.startswith("clumpprops")} - engines - commands
    assert "clumpprops.api" in geometry and "clumpprops.pairwise" in geometry
    for m in sorted(geometry):
        reach = _loads(m)
        assert not reach & engines, (m, reach & engines)
        assert "yade" not in set().union(GRAPH[m][1], *(GRAPH[d][1] for d in reach)), m
    for m in (m for m in MODULES if m.startswith("clumpprops")):
        assert not any(d.startswith("studies") for d in _loads(m)), m


def test_the_yade_script_knows_nothing_of_the_driver():
    src = (ROOT / "yade_scripts" / "granular_gas.py").read_text()
    tops = set()
    for node in ast.walk(ast.parse(src)):
        if isinstance(node, ast.Import):
            tops |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            tops.add(node.module.split(".")[0])
    assert {"yade", "numpy", "clumpprops"} <= tops
    assert not tops & {"studies", "dask", "distributed"}, tops


def test_reports_and_plots_never_run_a_simulation():
    for m in ("studies.report", "studies.gas_report", "studies.gas_plots", "studies.effects_plots"):
        reach = _loads(m)
        runs = {"studies.runner", "studies.engine", "studies.hard_sphere_md"}
        assert not reach & runs, (m, reach & runs)
        ext = set().union(GRAPH[m][1], *(GRAPH[d][1] for d in reach))
        assert not ext & {"yade", "dask", "distributed", "subprocess"}, (m, ext)
