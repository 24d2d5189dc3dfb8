"""Start-up: the compiled kernels are keyed on every source they contain, and the time spent
getting them is reported apart from the integration (``compile_s`` beside ``wall_s``).
Mechanisms only: nothing here is timed. (That a second process loads them from the disk
cache: tests/test_bounds.py, which compiles them afresh once for both.)"""

import ast
import os
from pathlib import Path

from wheelrom.runtime import kernel_cache as _kernel_cache
from wheelrom.transient.run import run_case

PACKAGE = os.path.dirname(os.path.dirname(_kernel_cache.__file__))
# wheelrom modules a kernel module may import for its Python side only (no compiled code)
# (and the runtime stage's face, a docstring only, which `from wheelrom.runtime import` loads)
PYTHON_SIDE = {"wheelrom.runtime.environment", "wheelrom.runtime.kernel_cache",
               "wheelrom.forces.parameters", "wheelrom.runtime",
               "wheelrom.transient.stuck_shift"}  # numpy: the basis of the context


def test_compile_time_is_reported_apart_from_wall_time(small_model, small_cfg):
    short = small_cfg.replace(**{"time.end": 1e-4, "time.window": 1e-4})
    run_case(small_model, short)
    again = run_case(small_model, short)
    assert again.compile_s == 0.0 and again.wall_s > 0
    assert again.summary()["compile_s"] == 0.0


def _wheelrom_imports(path):
    found = set()
    for node in ast.walk(ast.parse(Path(path).read_text())):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("wheelrom"):
            names = {f"{node.module}.{a.name}" for a in node.names}
            found |= ({node.module} - {"wheelrom"}) | names
    return found


def test_the_cache_key_covers_every_module_a_kernel_contains():
    """A kernel module imports (so may freeze into its code) only kernel modules."""
    kernels = {"wheelrom." + name[:-3].replace("/", ".") for name in _kernel_cache.KERNEL_SOURCES}
    for name in _kernel_cache.KERNEL_SOURCES:
        for imported in _wheelrom_imports(os.path.join(PACKAGE, name)):
            module = imported if imported in kernels | PYTHON_SIDE else imported.rpartition(".")[0]
            assert module in kernels | PYTHON_SIDE, f"{name} imports {imported}: a kernel source?"
    # every module with cached kernels is a kernel source (bench's loop: its own file is its key)
    for root, _, files in os.walk(PACKAGE):
        for file in files:
            path = os.path.join(root, file)
            rel = os.path.relpath(path, PACKAGE).replace(os.sep, "/")
            if file.endswith(".py") and "_kernel_cache.njit(" in Path(path).read_text():
                assert rel in _kernel_cache.KERNEL_SOURCES + ("bench/transient.py",), rel
