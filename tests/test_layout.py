"""The package layout the design promises: no import cycles, and who may import whom."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("models", "proofs", "falsify", "kernel", "testing", "cli", "api", "studies")
GENERIC = ("certiloop.models", "certiloop.proofs", "certiloop.falsify", "certiloop.kernel",
           "certiloop.testing", "certiloop.cli", "certiloop.api")
# what runs in a control loop: the runtime support and the case studies' kernels
RUNTIME = ("certiloop.kernel.filtered", "certiloop.kernel.decide", "certiloop.studies.sbs.fixture",
           "certiloop.studies.sbs.monitor",
           "certiloop.studies.sbs.native", "certiloop.studies.sbs.generated", "certiloop.studies.rcm.kernel",
           "certiloop.studies.rcm.arm", "certiloop.studies.rcm.cloud", "certiloop.studies.rcm.dynamics",
           "certiloop.studies.rcm.generated", "certiloop.studies.raven.arm",
           "certiloop.studies.raven.deviation",
           "certiloop.studies.dualarm.arms", "certiloop.studies.dualarm.generated")
PROVER = ("certiloop.proofs", "certiloop.falsify", "certiloop.cli", "certiloop.api")


def _modules() -> dict[str, Path]:
    out = {}
    for top in PACKAGES:
        for path in (ROOT / top).rglob("*.py"):
            parts = path.relative_to(ROOT).with_suffix("").parts
            name = "certiloop." + ".".join(parts)
            out[name.removesuffix(".__init__")] = path
    return out


def _imports(modules: dict[str, Path]) -> dict[str, set[str]]:
    """Every certiloop module a module imports, at top level or inside a function. Importing
    a submodule (`from pkg import sub`) counts as importing `sub`, not `pkg`'s other parts."""
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for name, path in modules.items():
        tree = ast.parse(path.read_text())
        typing_only = {id(n) for block in ast.walk(tree) if isinstance(block, ast.If)
                       and ast.unparse(block.test) == "TYPE_CHECKING" for n in ast.walk(block)}
        for node in ast.walk(tree):
            if id(node) in typing_only:  # annotations only, never imported at run time
                continue
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("certiloop"):
                subs = [f"{node.module}.{a.name}" for a in node.names if f"{node.module}.{a.name}" in modules]
                graph[name].update(subs)
                if len(subs) < len(node.names) and node.module in modules:
                    graph[name].add(node.module)
            elif isinstance(node, ast.Import):
                graph[name].update(a.name for a in node.names if a.name in modules)
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1 or v in graph[v]:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


GRAPH = _imports(_modules())


def test_no_import_cycles():
    assert _cycles(GRAPH) == []


def _importers(prefix: str) -> dict[str, set[str]]:
    return {m: {t for t in targets if t.startswith("certiloop.")}
            for m, targets in GRAPH.items() if m.startswith(prefix)}


def test_models_import_nothing_of_ours_but_models():
    for module, targets in _importers("certiloop.models").items():
        assert all(t.startswith("certiloop.models") for t in targets), module


def test_the_language_imports_only_itself():
    for module, targets in _importers("certiloop.models.lang").items():
        assert all(t.startswith("certiloop.models.lang") for t in targets), module


def test_the_trusted_core_imports_only_the_language_and_itself():
    for module, targets in _importers("certiloop.proofs.core").items():
        bad = [t for t in targets if not t.startswith(("certiloop.models.lang", "certiloop.proofs.core"))]
        assert not bad, (module, bad)


def test_nothing_in_the_core_can_be_reached_around():
    """Only the core decides verdicts: no module outside it defines a function of that name."""
    for name, path in _modules().items():
        if name.startswith("certiloop.proofs.core"):
            continue
        tree = ast.parse(path.read_text())
        defined = {n.name for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
        assert not defined & {"judge", "decide_theorem", "ObligationResult"}, name


def test_no_generic_package_imports_a_case_study():
    """The language, prover, falsifier, extraction, CLI and API know no case study by name:
    studies register themselves (models/library/registry.py)."""
    for module, targets in GRAPH.items():
        if module.startswith(GENERIC):
            bad = [t for t in targets if t.startswith("certiloop.studies")]
            assert not bad, (module, bad)


def test_the_runtime_kernels_import_no_prover():
    runtime = [m for m in GRAPH if m.startswith(RUNTIME)]
    assert len(runtime) >= len(RUNTIME)  # every name above exists
    for module in runtime:
        bad = [t for t in GRAPH[module] if t.startswith(PROVER)]
        assert not bad, (module, bad)


def test_the_api_imports_no_cli():
    for module, targets in _importers("certiloop.api").items():
        assert not [t for t in targets if t.startswith("certiloop.cli")], module


def test_each_study_is_registered_and_has_a_readme():
    from certiloop.models.library.registry import studies

    registered = {s.name for s in studies()}
    folders = {p.name for p in (ROOT / "studies").iterdir() if (p / "__init__.py").exists()}
    assert registered == folders
    for name in folders:
        assert (ROOT / "studies" / name / "README.md").exists(), name


def test_no_module_imports_another_modules_private_names():
    """A name another module needs is part of its module's interface: public, no underscore."""
    found = []
    for name, path in _modules().items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("certiloop") \
                    and node.module != name:
                found += [(name, node.module, a.name) for a in node.names
                          if a.name.startswith("_") and not a.name.startswith("__")]
    assert found == []


# One file name, one job: the same name in two places only where it is the same job done for a
# different target (each study's own models, arm or planner; the Python and the C printer of one
# construct; a package's own error type; interval arithmetic on scalars and on numpy arrays).
SAME_JOB = {
    "study.py", "models.py", "demo.py", "arm.py", "planner.py", "builtdr.py", "lyapunov.py", "plots.py",
    "certified.py", "scalar.py", "errors.py", "intervals.py",
}


def test_no_two_modules_share_a_name_for_different_jobs():
    seen: dict[str, list[str]] = {}
    for name, path in _modules().items():
        if path.name not in ("__init__.py", "__main__.py"):
            seen.setdefault(path.name, []).append(name)
    shared = {file: names for file, names in seen.items() if len(names) > 1 and file not in SAME_JOB}
    assert shared == {}


def test_the_lazy_language_names_are_the_statically_visible_ones():
    """certiloop.models loads its names on first use; the same names are imported under
    TYPE_CHECKING for type checkers, IDEs and the documentation. The two lists agree."""
    import certiloop.models as models

    tree = ast.parse((ROOT / "models" / "__init__.py").read_text())
    static = {alias.name for block in ast.walk(tree) if isinstance(block, ast.If)
              and ast.unparse(block.test) == "TYPE_CHECKING" for node in ast.walk(block)
              if isinstance(node, ast.ImportFrom) for alias in node.names}
    assert static == set(models.__all__)
    assert all(getattr(models, name) is not None for name in static)
