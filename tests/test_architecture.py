"""The house: imports flow one way through the stages, no cycles, every module imports on
its own, modules and functions stay small."""

import ast
import os
import subprocess
import sys
from pathlib import Path

from conftest import HANG_S

SRC = os.path.join(os.path.dirname(os.path.dirname(__file__)), "src")
PACKAGE = os.path.join(SRC, "wheelrom")

# stage of every module (by dotted-name prefix, longest first): a module may import only its
# own stage and earlier ones (docs/usage.md, "The code"); a folder is a stage
STAGES = (
    ("wheelrom.runtime", 0), ("wheelrom._environment", 0), ("wheelrom.config", 1),
    ("wheelrom.segment", 2), ("wheelrom.rom", 3), ("wheelrom.forces", 4),
    ("wheelrom.transient", 5), ("wheelrom.analysis", 6), ("wheelrom.results", 7),
    ("wheelrom.studies", 8), ("wheelrom.bench", 9), ("wheelrom.plots", 10),
    ("wheelrom.cli", 11), ("wheelrom.__main__", 12), ("wheelrom", 0),
)
# the top level: the package face, the shim of the old environment module and
# `python -m wheelrom` (the entry point, as the console script), nothing else
TOP_LEVEL = {"wheelrom", "wheelrom._environment", "wheelrom.__main__"}
ENTRY_POINTS = {"wheelrom.__main__"}

# compiled kernels kept as one fused pass each (docs/performance.md: the fusion is the
# speed); everything else is held under the limits
LONG_KERNELS = {"rhs_core", "sample_core", "contacts", "_contact_columns"}


def _modules():
    out = {}
    for root, _, files in os.walk(PACKAGE):
        for name in files:
            if name.endswith(".py"):
                path = os.path.join(root, name)
                dotted = os.path.relpath(path, SRC)[:-3].replace(os.sep, ".")
                out[dotted.removesuffix(".__init__")] = path
    return out


def _stage(module):
    return next(rank for prefix, rank in STAGES if module == prefix or
                module.startswith(prefix + "."))


def _imports(path, module, known):
    """Every wheelrom module ``module`` imports, at module level or inside functions."""
    found = set()
    for node in ast.walk(ast.parse(Path(path).read_text())):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            assert not node.level, f"{module}: relative import (use wheelrom.<stage>...)"
            base = node.module or ""
            names = [f"{base}.{a.name}" for a in node.names] + [base]
        else:
            continue
        for name in names:
            while name and name not in known:
                name = name.rpartition(".")[0]
            if name and name != module:
                found.add(name)
    return found - {"wheelrom"}


def test_imports_flow_one_way_without_cycles():
    modules = _modules()
    graph = {m: _imports(p, m, modules) for m, p in modules.items()}
    upward = [(m, d) for m, deps in graph.items() for d in deps if _stage(d) > _stage(m)]
    assert not upward, f"imports against the stage order: {upward}"
    state = {}

    def visit(m, path):
        state[m] = "open"
        for d in sorted(graph[m]):
            if state.get(d) == "open":
                raise AssertionError(f"import cycle: {' -> '.join([*path, m, d])}")
            if d not in state:
                visit(d, [*path, m])
        state[m] = "done"

    for m in sorted(graph):
        if m not in state:
            visit(m, [])
    assert graph["wheelrom.transient.kernel"]
    importers = {m for m, deps in graph.items() if "wheelrom.cli.main" in deps}
    assert importers <= ENTRY_POINTS, f"only an entry point imports the CLI: {importers}"
    assert not [m for m, deps in graph.items() if deps & ENTRY_POINTS], "an entry point imported"


def test_every_module_imports_on_its_own():
    """Each module imported into a fresh interpreter state (no other wheelrom module loaded)."""
    names = sorted(_modules())
    code = (
        "import importlib, sys\n"
        f"for name in {names!r}:\n"
        "    for loaded in [k for k in sys.modules if k.startswith('wheelrom')]:\n"
        "        del sys.modules[loaded]\n"
        "    importlib.import_module(name)\n"
        "print('ok')\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=HANG_S, env=dict(os.environ, PYTHONPATH=SRC))
    assert res.returncode == 0 and res.stdout.strip() == "ok", res.stderr[-2000:]


#: lines a module stays under. Modules are split by concept (one thing a newcomer looks for,
#: named by its package's face), reviewed when a change lands, not to fit a number: a cap
#: close to the modules' sizes forced splits by line count (a mixin holding half of a class,
#: one function parked in an unrelated module). This one only flags a module that has grown
#: into several concepts, to be split along them.
MODULE_LINES = 800


def test_modules_and_functions_stay_small():
    """Modules under :data:`MODULE_LINES` lines, functions under 80 (the fused compiled
    kernels excepted)."""
    limit, too_long = MODULE_LINES, []
    for module, path in _modules().items():
        text = Path(path).read_text()
        if text.count("\n") >= limit:
            too_long.append((module, text.count("\n")))
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef) and node.name not in LONG_KERNELS:
                length = node.end_lineno - node.lineno + 1
                if length >= 80:
                    too_long.append((f"{module}.{node.name}", length))
    assert not too_long, too_long


def test_a_folder_is_a_stage():
    """Every module lives in a stage's folder (the top level holds only the package face and
    the old environment shim), and every stage's face says what it owns and may import."""
    modules = _modules()
    stray = [m for m in modules if m.count(".") < 2 and m not in TOP_LEVEL
             and m.rpartition(".")[2] not in {p.rpartition(".")[2] for p, _ in STAGES}]
    assert not stray, f"modules outside a stage folder: {stray}"
    for prefix, _ in STAGES:
        path = modules.get(prefix)
        if prefix in TOP_LEVEL or path is None:
            continue
        doc = ast.get_docstring(ast.parse(Path(path).read_text())) or ""
        assert "May import" in doc, f"{prefix}: its face does not say what it may import"



def test_every_package_face_names_its_modules():
    """A package's face (its ``__init__.py`` docstring) names each of its modules and
    subpackages (``:mod:`.name``` or a dotted path ending in it): where a newcomer starts."""
    unnamed = []
    for init in sorted(Path(PACKAGE).rglob("__init__.py")):
        doc = ast.get_docstring(ast.parse(init.read_text())) or ""
        for child in sorted(init.parent.iterdir()):
            if child.suffix == ".py" and child.name != "__init__.py":
                name = child.stem
            elif (child / "__init__.py").is_file():
                name = child.name
            else:
                continue
            if f".{name}`" not in doc:
                unnamed.append(str(child.relative_to(SRC)))
    assert not unnamed, f"modules their package's face does not name: {unnamed}"

#: every periodic-solution method lives in ``analysis.periodic`` (issue #46): a newcomer finds
#: the harmonic balance, continuation, Hopf points, Floquet (Hill and monodromy), shooting and
#: settle in one room; ``analysis`` itself keeps the linear analyses
PERIODIC = {"harmonic_balance", "continuation", "floquet", "hopf", "cycle_transient",
            "limit_cycle", "shooting", "monodromy", "settle", "flow", "exact", "forced_wave",
            "forced_branch", "forced_shooting", "window", "hysteresis"}
LINEAR = {"jacobian", "stability", "margin", "forced", "forced_peak"}


def test_periodic_solutions_live_in_one_package():
    modules = _modules()
    analysis = {m.rpartition(".")[2] for m in modules
                if m.startswith("wheelrom.analysis.") and m.count(".") == 2}
    periodic = {m.rpartition(".")[2] for m in modules
                if m.startswith("wheelrom.analysis.periodic.")}
    assert PERIODIC <= periodic, PERIODIC - periodic
    assert analysis - {"periodic"} <= LINEAR, analysis - {"periodic"} - LINEAR
