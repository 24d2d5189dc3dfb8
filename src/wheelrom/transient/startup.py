"""What a fresh process costs before its first TS step (``wheelrom bench``'s ``startup_s``).

``python -m wheelrom.transient.startup CASE`` (``CASE``: a pickled ``(model, cfg)``) imports
what ``wheelrom run`` imports, makes the compiled kernels ready (:func:`load_kernels`: from the
kernel cache, else compiled), integrates one TS step of the case and prints JSON on stdout:

- ``first_step_at``: ``time.monotonic()`` [s] at the end of the first step (the caller
  subtracts its own ``time.monotonic()`` at the spawn: one system-wide clock on Linux);
- ``compile_s``: seconds spent loading or compiling the kernels;
- ``kernel_cache``: this process's cache look-ups (``hits``: loaded, ``misses``: compiled);
- ``compiled_in_run``: numba compile events and kernel-cache look-ups during the run (0:
  :func:`load_kernels` covers everything a run needs, so ``wall_s`` is integration only);
- ``run_compile_s``: the ``compile_s`` the run reports (0: the kernels were ready);
- ``messages``: what the kernel cache announced (``"compiling kernels (first run only)"``).

The model is given, not built: building it is the configuration's physics (mesh, FE matrices,
SLEPc modes: ``model.info["build_s"]``), not start-up overhead.
"""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import tempfile
import time


def _first_step(path: str) -> dict:
    """Load the case at ``path``, run its first step; the figures of the module docstring."""
    from numba.core import event

    from wheelrom.forces.parameters import force_parameters
    from wheelrom.runtime import kernel_cache as _kernel_cache
    from wheelrom.transient.run import load_kernels, run_case
    from wheelrom.transient.ts import time_step

    messages: list[str] = []
    _kernel_cache.set_log(messages.append)  # as the command line, which prints them
    with open(path, "rb") as f:
        model, cfg = pickle.load(f)
    h = time_step(cfg)
    # one step, one window, a sample in it (a window without one is refused)
    cfg = cfg.replace(**{"time.end": h, "time.window": h, "output.sample_rate_hz": 1 / h,
                         "output.history_rate_hz": 1 / h, "output.state_rate_hz": 0.0})
    compile_s = load_kernels(force_parameters(model, cfg, None))
    looked_up = dict(_kernel_cache.lookups)
    marks = []
    with event.install_recorder("numba:compile") as recorded:
        res = run_case(model, cfg, progress=lambda *_: marks.append(time.monotonic()))
    in_run = sum(_kernel_cache.lookups.values()) - sum(looked_up.values())
    return {
        "first_step_at": marks[0] if marks else None,
        "status": res.status,
        "compile_s": compile_s,
        "kernel_cache": looked_up,
        "compiled_in_run": in_run + len(recorded.buffer),
        "run_compile_s": res.compile_s,
        "messages": messages,
    }


def _spawn(path: str, cache_dir: str) -> dict:
    """One fresh process on the case at ``path`` with the kernel cache in ``cache_dir``: its
    figures, and ``startup_s`` from the spawn to the end of its first step."""
    import wheelrom

    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    source = os.path.dirname(os.path.dirname(os.path.abspath(wheelrom.__file__)))
    env["PYTHONPATH"] = os.pathsep.join(p for p in (source, env.get("PYTHONPATH")) if p)
    t0 = time.monotonic()
    done = subprocess.run([sys.executable, "-m", __name__, path], env=env,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"start-up probe failed: {done.stderr[-2000:]}")
    out = json.loads(done.stdout)
    out["startup_s"] = out["first_step_at"] - t0
    return out


def measure(model, cfg, cache_dir: str | None = None) -> dict:
    """Start-up of a fresh process on ``model`` and ``cfg`` (one step), cold (an empty kernel
    cache: it compiles) then warm (the same cache again: it loads), each in its own process:
    ``{"cold": {...}, "warm": {...}}``, the figures of :func:`_first_step` and ``startup_s``
    [s] (spawn to the end of the first step). ``cache_dir``: a new or empty directory for
    that cache, kept afterwards (None: a temporary one, removed). The processes inherit this one's
    environment (``NUMBA_BOUNDSCHECK``, say)."""
    with tempfile.TemporaryDirectory(prefix="wheelrom-startup-") as tmp:
        path = os.path.join(tmp, "case.pickle")
        with open(path, "wb") as f:
            pickle.dump((model, cfg), f)
        cache = cache_dir or os.path.join(tmp, "kernel-cache")
        return {"cold": _spawn(path, cache), "warm": _spawn(path, cache)}


def main(argv: list[str]) -> int:
    from wheelrom.runtime.environment import bootstrap

    bootstrap()  # as the command line: before numpy loads
    print(json.dumps(_first_step(argv[0])))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
