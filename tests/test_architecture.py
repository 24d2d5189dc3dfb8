"""The house: imports flow one way through the stages, no cycles, every module imports on
its own, modules and functions stay small."""

import ast
import os
import subprocess
import sys

SRC = os.path.join(os.path.dirname(os.path.dirname(__file__)), "src")
PACKAGE = os.path.join(SRC, "wheelrom")

# stage of every module (by dotted-name prefix): a module may import only its own stage and
# earlier ones (docs/usage.md, "The code")
STAGES = (
    ("wheelrom._environment", 0), ("wheelrom.errors", 0), ("wheelrom._config_values", 0),
    ("wheelrom.config", 0), ("wheelrom._config_forced", 0), ("wheelrom.outputs", 0),
    ("wheelrom.interrupts", 0),
    ("wheelrom.study_config", 0),
    ("wheelrom.segment", 1), ("wheelrom.rom", 2),
    ("wheelrom.forces", 3), ("wheelrom.transient", 4), ("wheelrom.results", 5),
    ("wheelrom.info", 5), ("wheelrom.csv_export", 5), ("wheelrom.sweep", 6),
    ("wheelrom.histories", 5), ("wheelrom.reconstruct", 5), ("wheelrom.wheel_motion", 6),
    ("wheelrom.plots_motion", 7), ("wheelrom.cli_motion", 8),
    ("wheelrom.cli_forced", 8),
    ("wheelrom.stability_study", 6), ("wheelrom.study_plan", 5), ("wheelrom.study_file", 5),
    ("wheelrom.study", 6), ("wheelrom.plots_study", 7), ("wheelrom.mistuning_study", 6),
    ("wheelrom.plots_montecarlo", 7),
    ("wheelrom.bench", 7), ("wheelrom.plots", 7), ("wheelrom.plots_stability", 7),
    ("wheelrom.plot_helpers", 7),
    ("wheelrom.cli_args", 8), ("wheelrom.cli_output", 8), ("wheelrom.cli_tools", 8),
    ("wheelrom.cli_output_mistuning", 8),
    ("wheelrom.cli", 8), ("wheelrom", 0),
)  # fmt: skip

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
                module.startswith(prefix + "."))  # fmt: skip


def _imports(path, module, known):
    """Every wheelrom module ``module`` imports, at module level or inside functions."""
    found = set()
    for node in ast.walk(ast.parse(open(path).read())):
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
    assert graph["wheelrom.transient.kernel"] and "wheelrom.cli" not in set().union(*graph.values())


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
                         timeout=300, env=dict(os.environ, PYTHONPATH=SRC))  # fmt: skip
    assert res.returncode == 0 and res.stdout.strip() == "ok", res.stderr[-2000:]


def test_modules_and_functions_stay_small():
    """Modules under 500 lines, functions under 80 (the fused compiled kernels excepted)."""
    limit, too_long = 500, []
    for module, path in _modules().items():
        text = open(path).read()
        if text.count("\n") >= limit:
            too_long.append((module, text.count("\n")))
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef) and node.name not in LONG_KERNELS:
                length = node.end_lineno - node.lineno + 1
                if length >= 80:
                    too_long.append((f"{module}.{node.name}", length))
    assert not too_long, too_long
