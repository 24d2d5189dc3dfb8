"""The compiled kernels' disk cache (numba) and what this process spends getting them.

Every numba kernel of the package (the transient right-hand side and monitor, their C
callbacks, the reference force model) is compiled once per machine and then loaded from
numba's cache directory (``NUMBA_CACHE_DIR``, else ``__pycache__`` beside the sources):
~0.25 s instead of ~20 s for what a run needs (docs/performance.md, "Start-up").

Why not numba's ``cache=True`` alone: it keys a function's machine code on its own file
(modification time and size) only, so a change in a function it calls from another module
(``rhs_core`` calls ``contacts``, the C callbacks link ``rhs_core``, the layout constants are
frozen into the code) would load stale code. :func:`njit` and :func:`cfunc` key every kernel on
the contents of all of :data:`KERNEL_SOURCES` as well: editing any of them recompiles them all.

At the first cache miss of a process the ``log`` set by :func:`set_log` (the command line's
stderr) receives ``"compiling kernels (first run only)"``; library code prints nothing itself.
"""

from __future__ import annotations

import functools
import hashlib
import os
import warnings
from collections.abc import Callable

# modules whose code (or constants) a cached kernel contains, relative to the package
KERNEL_SOURCES = (
    "transient/kernel.py",
    "transient/contact_kernel.py",
    "forces/fastmath.py",
    "transient/layout.py",
    "transient/bridge.py",
    "transient/exponential_kernel.py",
    "forces/reference.py",
    "forces/contact_law.py",
)

COMPILING_MESSAGE = "compiling kernels (first run only)"

# the wheelrom package (this module sits in its runtime/ stage)
_PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
_log: list[Callable[[str], None] | None] = [None]
# cache look-ups of this process: "hits" (loaded), "misses" (compiled, then saved)
lookups = {"hits": 0, "misses": 0}


def set_log(log: Callable[[str], None] | None) -> None:
    """Where :data:`COMPILING_MESSAGE` goes (once per process, at the first cache miss);
    ``None``: nowhere (the default)."""
    _log[0] = log


@functools.cache
def sources_digest() -> str:
    """SHA-256 of the contents of :data:`KERNEL_SOURCES` (read once per process, ~1 ms)."""
    digest = hashlib.sha256()
    for name in KERNEL_SOURCES:
        with open(os.path.join(_PACKAGE, name), "rb") as f:
            digest.update(name.encode() + b"\0" + f.read())
    return digest.hexdigest()


@functools.cache
def _cache_class():
    """numba's ``FunctionCache`` with the index stamped by :func:`sources_digest` too, counting
    look-ups in :data:`lookups` (a class made on first use: numba is imported lazily)."""
    from numba.core.caching import FunctionCache, IndexDataCacheFile

    class SourceKeyedCache(FunctionCache):
        def __init__(self, py_func):
            super().__init__(py_func)
            stamp = (self._impl.locator.get_source_stamp(), sources_digest())
            self._cache_file = IndexDataCacheFile(cache_path=self._cache_path,
                                                  filename_base=self._impl.filename_base,
                                                  source_stamp=stamp)

        def load_overload(self, sig, target_context):
            found = super().load_overload(sig, target_context)
            _count(found is not None)
            return found

    return SourceKeyedCache


def _count(hit: bool) -> None:
    if hit:
        lookups["hits"] += 1
        return
    if not lookups["misses"] and _log[0] is not None:
        _log[0](COMPILING_MESSAGE)
    lookups["misses"] += 1


def _enable(compiled, py_func) -> None:
    """Give a numba dispatcher or ``CFunc`` the source-keyed cache (numba internals: a numba
    without them leaves the kernels uncached, with a warning, rather than keyed on one file)."""
    try:
        compiled._cache = _cache_class()(py_func)
    except (ImportError, AttributeError, TypeError) as exc:
        warnings.warn(f"wheelrom: kernels not cached on disk (this numba: {exc})", stacklevel=3)


def njit(**options):
    """``numba.njit(**options)`` with the source-keyed disk cache (compiles lazily, at the
    first call, as ``numba.njit``)."""
    import numba

    def decorate(py_func):
        dispatcher = numba.njit(**options)(py_func)
        _enable(dispatcher, py_func)
        return dispatcher

    return decorate


def cfunc(signature, py_func):
    """A numba C callback of ``py_func`` (a module-level function) with C ``signature``,
    loaded from the source-keyed disk cache, else compiled and saved. A C callback is
    cacheable only without dynamic globals: it must not call ctypes function objects
    (``numba.types.ExternalFunction`` symbols registered with ``llvmlite.binding.add_symbol``
    are fine)."""
    from numba.core import sigutils
    from numba.core.ccallback import CFunc

    callback = CFunc(py_func, sigutils.normalize_signature(signature), locals={}, options={})
    _enable(callback, py_func)
    callback.compile()
    return callback
