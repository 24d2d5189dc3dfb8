"""The compiled kernels in fresh processes: they are cached on disk (a second process loads
them), and nothing compiled reads past an array's end (the CI failure of 2026-11-26: a test
model of 6 modes with 3-mode aero and excitation arrays, read past their end by the force
kernel, gave NaN on the CI machine and finite garbage on the developers').

numba compiles without bounds checks; processes with ``NUMBA_BOUNDSCHECK=1`` and their own
kernel cache (so that no checked kernel reaches the real cache) first probe the start-up
(cold: compiles; warm: loads), then run every compiled consumer of the force parameters on the
small wheel under both contact laws: the reference forces, the harmonic balance's AFT and its
marched Jacobian, and a transient (the compiled right-hand side through PETSc's C callbacks).
An index out of bounds raises ``IndexError`` there; a control first proves the checks are on
(a shortened array is caught). One test, one compilation: the two were each the suite's
longest (72 and 58 s of compiling the same kernels).
"""

import os
import subprocess
import sys

from conftest import HANG_S, SMALL
from wheelrom.runtime import kernel_cache as _kernel_cache
from wheelrom.transient import startup

SCRIPT = r"""
import math
import sys

import numpy as np

from wheelrom import config
from wheelrom.analysis.periodic.forced_wave import ForcedWave
from wheelrom.forces.parameters import force_parameters
from wheelrom.forces.reference import ReferenceForces
from wheelrom.rom.build import build_model
from wheelrom.runtime.environment import petsc
from wheelrom.transient.run import run_case

small = sys.argv[1]
for law in ("paper", "elastic"):
    cfg = config.load(small, overrides=[f"contacts.law='{law}'", "time.end=2e-4",
                                        "time.window=1e-4"])
    model = build_model(cfg, petsc().COMM_SELF)
    params = force_parameters(model, cfg)
    if law == "paper":  # the control: a shortened array is caught
        short = force_parameters(model, cfg)
        object.__setattr__(short, "excitation", short.excitation[:2].copy())
        z = np.zeros((model.blades, model.modes))
        try:
            ReferenceForces(short).evaluate(0.0, z, z)
            print("control: not caught")
        except IndexError:
            print("control: caught")
    rng = np.random.default_rng(0)
    q, v = rng.normal(size=(2, model.blades, model.modes)) * 1e-6
    ReferenceForces(params).evaluate(0.0, q, v)
    problem = ForcedWave(model, params, cfg.wheel.damping_beta, 2, 24, 1.0)
    X = np.zeros((5, model.modes))
    X[1] = 1e-6
    problem.balance.jacobian(X, 2 * math.pi * 120.0, 1.0)
    result = run_case(model, cfg)
    print(law, result.status)
"""


def test_kernels_load_in_a_second_process_and_read_no_array_past_its_end(
        small_model, small_cfg, tmp_path, monkeypatch):
    cache = tmp_path / "kernels"
    monkeypatch.setenv("NUMBA_BOUNDSCHECK", "1")  # the processes': numba here is configured
    # start-up: a cold process compiles (and says so once), a second one loads every kernel
    probe = startup.measure(small_model, small_cfg, cache_dir=str(cache))
    cold, warm = probe["cold"], probe["warm"]
    assert cold["status"] == warm["status"] == "done"
    assert cold["kernel_cache"]["misses"] > 0 and cold["compile_s"] > 0
    assert cold["messages"] == [_kernel_cache.COMPILING_MESSAGE]  # once per process
    # rhs, monitor, reference forces, the exponential step, the sliders' return at a solve's end
    assert warm["kernel_cache"] == {"hits": 5, "misses": 0}
    assert warm["messages"] == []
    for proc in (cold, warm):  # nothing compiled or loaded once the run's clock started
        assert proc["compiled_in_run"] == 0 and proc["run_compile_s"] == 0.0
        assert proc["startup_s"] > 0
    # every consumer of the force parameters, checked (the run's kernels from that cache)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), WHEELROM_MODEL_CACHE="off")
    done = subprocess.run([sys.executable, "-c", SCRIPT, SMALL], capture_output=True,
                          text=True, env=env, timeout=HANG_S)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.split("\n")[:3] == ["control: caught", "paper done", "elastic done"], \
        done.stdout + done.stderr[-3000:]
