"""The transient of a mistuned wheel (issue #22): the compiled kernel's blade-specific
diagonal blocks ``A0 + delta_s K_seg`` against the reference force model with the dense
mistuned ``K_R``, the serial reference integration, the energy balance and the linear forced
response."""

import dataclasses
import math

import numpy as np
import pytest

from wheelrom.analysis import forced
from wheelrom.forces.parameters import force_parameters
from wheelrom.rom.model import nodal_diameter
from wheelrom.runtime.environment import petsc
from wheelrom.transient import bridge
from wheelrom.transient.problem import WheelProblem
from wheelrom.transient.reference import reference_solution
from wheelrom.transient.run import run_case, run_cases

SELF = petsc().COMM_SELF


def _mistuned(model, std: float = 0.03, seed: int = 5):
    delta = std * np.random.default_rng(seed).standard_normal(model.blades)
    return dataclasses.replace(model, mistuning=delta)


@pytest.mark.parametrize("vdp", ["off", "relative"])
def test_compiled_rhs_of_a_mistuned_wheel_equals_the_reference(coarse_model, coarse_cfg, vdp):
    """Two implementations: the kernel's ``delta_s K_seg`` rows (in its rotated basis) against
    the reference forces + the dense mistuned ``K_R``, damping power included; the tuned
    kernel on the same state differs from both (the mistuning is not a no-op)."""
    cfg = coarse_cfg.replace(**{"flutter.model": vdp, "flutter.mu": 2e3})
    model = _mistuned(coarse_model)
    angles = {"shroud": 50.0, "tieboss": 45.0}
    problem = WheelProblem(model, cfg, [force_parameters(model, cfg, angles)], SELF)
    rng = np.random.default_rng(11)
    u = rng.normal(size=problem.size()) * 2e-3
    n = problem.n
    u[n : 2 * n] *= 1000.0
    expected = problem.rhs_numpy(0.0071, u)
    got = bridge.evaluate(problem.context, 0.0071, u)
    scale = np.abs(expected[n : 2 * n]).max()
    assert np.abs(got[: 2 * n] - expected[: 2 * n]).max() < 1e-12 * scale
    np.testing.assert_allclose(got[2 * n :], expected[2 * n :], rtol=1e-10)
    tuned = WheelProblem(coarse_model, cfg, [force_parameters(coarse_model, cfg, angles)], SELF)
    untouched = bridge.evaluate(tuned.context, 0.0071, u)
    assert np.abs(untouched[n : 2 * n] - expected[n : 2 * n]).max() > 1e-3 * scale


def test_mistuned_transient_equals_the_serial_reference(coarse_model, coarse_cfg):
    """PETSc TS with the compiled kernel against the numpy RK3 reference (dense mistuned
    ``K_R``), all forces on, 2000 steps."""
    steps = 2000
    cfg = coarse_cfg.replace(**{"time.end": steps * 5e-6, "time.window": steps * 5e-6})
    model = _mistuned(coarse_model)
    res = run_case(model, cfg)
    assert res.status == "done" and res.steps == steps
    _, states, _ = reference_solution(model, cfg, steps, 5e-6, sample_every=steps)
    n = model.size
    ref, got = states[-1][: 2 * n], res.final_state[: 2 * n]
    tuned = run_case(coarse_model, cfg).final_state[: 2 * n]
    assert np.abs(got - ref).max() <= 1e-9 * np.abs(ref).max()
    assert np.abs(tuned - ref).max() > 1e-3 * np.abs(ref).max()


def test_zero_mistuning_is_the_tuned_transient_bitwise(small_model, small_cfg):
    """An all-zero pattern is the tuned wheel: the same kernel path, the same bits, batch
    included; a mistuned batch gives each case its result alone (bitwise)."""
    cfg = small_cfg.replace(**{"time.end": 0.002, "time.window": 0.001})
    angles = [{"shroud": a, "tieboss": 45.0} for a in (20.0, 70.0)]
    zero = dataclasses.replace(small_model, mistuning=np.zeros(small_model.blades))
    for a, b in zip(run_cases(small_model, cfg, angles), run_cases(zero, cfg, angles),
                    strict=True):
        assert np.array_equal(a.tip_history, b.tip_history)
        assert np.array_equal(a.final_state, b.final_state)
    mistuned = _mistuned(small_model)
    batch = run_cases(mistuned, cfg, angles)
    for res, a in zip(batch, angles, strict=True):
        alone = run_case(mistuned, cfg, a)
        assert np.array_equal(alone.tip_history, res.tip_history)
        assert np.array_equal(alone.work, res.work)


def test_energy_balance_closes_on_a_mistuned_wheel(coarse_model, coarse_cfg):
    """E - E0 = the works (nozzle, Van der Pol, friction, damping), the strain energy and the
    damping power of the mistuned ``K_R``: within the RK3 error of the tuned test."""
    cfg = coarse_cfg.replace(**{"time.end": 0.01, "time.window": 0.0025})
    res = run_case(_mistuned(coarse_model), cfg)
    assert res.status == "done" and res.work[-1, 3] < 0
    assert res.energy_balance_error() < 5e-3


@pytest.mark.parametrize("alternate", [0.0, 0.01])
def test_mistuned_resonance_equals_the_transient_steady_state(small_cfg, comm, alternate):
    """At the largest peak of the ND-2 family-2 resonance (contacts and Van der Pol off,
    damping raised so that the start transient dies within the run) the transient's tip motion
    over its last 0.1 s has the forced response's amplitude on every blade (0.5 %), tuned and
    alternately mistuned (the two split standing waves respond unequally)."""
    from scipy.optimize import minimize_scalar

    from wheelrom.rom.build import build_model, quiet

    linear = {
        "contacts.tieboss.enabled": False,
        "contacts.shroud.enabled": False,
        "flutter.mu": 0.0,
        "segment.prestress": False,
        "wheel.damping_beta": 2e-5,
        "time.end": 0.3,
        "time.window": 0.015,
        "output.history_rate_hz": 20000.0,
        "mistuning.alternate": alternate,
    }
    cfg = small_cfg.replace(**linear)
    model = build_model(cfg, comm, log=quiet)
    n_s = cfg.wheel.stator_vanes
    K, C = forced.operators(model, cfg, contacts=False)
    F = forced.nozzle_amplitude(model, n_s, cfg.excitation.force)
    w0 = 2 * math.pi * model.frequencies_by_nodal_diameter()[nodal_diameter(n_s, model.blades), 2]
    found = minimize_scalar(
        lambda w: -forced.tip_amplitudes(model, forced.direct_solve(K, C, F, w)).max(),
        bounds=(0.98 * w0, 1.02 * w0), method="bounded", options={"xatol": 1e-8 * w0})
    w = found.x
    steady = forced.forced_response(model, cfg, [w], contacts=False).blade_amplitude[0]
    if alternate:
        assert steady.max() / steady.min() > 1.05  # localised: not a travelling wave
    res = run_case(model, cfg.replace(**{"wheel.speed_hz": w / (2 * math.pi * n_s)}))
    assert res.status == "done"
    t, tip = res.sample_time, res.tip_history
    period = 2 * math.pi / w
    keep = t > t[-1] - math.floor(0.1 / period) * period + 1e-12  # whole periods
    basis = np.stack([np.cos(w * t[keep]), np.sin(w * t[keep]), np.ones(keep.sum())], axis=1)
    coef = np.linalg.lstsq(basis, tip[keep].reshape(keep.sum(), -1), rcond=None)[0]
    fitted = np.sqrt(coef[0] ** 2 + coef[1] ** 2).reshape(-1, 3)  # |a - i b| per component
    transient = np.sqrt((fitted**2).sum(axis=1))
    assert np.abs(transient / steady - 1).max() <= 5e-3


def test_sweep_of_a_mistuned_wheel_runs_and_records_the_pattern(tmp_path):
    """``wheelrom sweep`` on a mistuned wheel: the cases run, the file holds the pattern the
    model used, and the tip histories differ from the tuned wheel's."""
    import h5py

    from conftest import SMALL
    from wheelrom.cli import main as cli

    quick = ["--set", "time.end=0.002", "--set", "time.window=0.001",
             "--set", "sweep.shroud_angles_deg=[30.0]"]
    tips = []
    for name, extra in (("tuned", []), ("mistuned", ["--set", "mistuning.alternate=0.02"])):
        out = tmp_path / f"{name}.h5"
        assert cli.main(["sweep", SMALL, "--out", str(out), *quick, *extra]) == 0
        with h5py.File(out) as f:
            assert all(s.decode().startswith("done") for s in f["/cases/status"][()])
            tips.append(f["/cases/tip_history"][()])
            if extra:
                delta = f["/model/mistuning"][()]
                np.testing.assert_array_equal(delta, 0.02 * (-1.0) ** np.arange(delta.size))
    assert np.abs(tips[0] - tips[1]).max() > 1e-3 * np.abs(tips[0]).max()


def test_preload_start_of_a_mistuned_wheel_is_its_static_equilibrium(small_model, small_cfg):
    """time.start = "preload" on a mistuned wheel: the start has zero accelerations under the
    mistuned ``K_R`` (not the tuned one), and the compiled kernel agrees at that state."""
    from wheelrom.transient.preload import initial_state

    cfg = small_cfg.replace(**{"time.start": "preload", "time.end": 5e-4, "time.window": 5e-4})
    model = _mistuned(small_model, std=0.05)
    problem = WheelProblem(model, cfg, [force_parameters(model, cfg, {"shroud": 50.0})], SELF)
    u0, residual = initial_state(problem)
    n = problem.n
    scale = np.abs(problem.Kd @ u0[:n]).max()
    acc = problem.rhs_numpy(0.0, u0)[n : 2 * n]
    assert scale > 0 and np.abs(acc).max() < 1e-9 * scale and residual < 1e-9 * scale
    compiled = bridge.evaluate(problem.context, 0.0, u0)
    tuned_acc = -(small_model.dense_stiffness() - problem.Kd) @ u0[:n]  # what tuned K_R adds
    assert np.abs(tuned_acc).max() > 1e-3 * scale  # the mistuning matters at this state
    assert np.abs(compiled[n : 2 * n] - acc).max() < 1e-9 * scale
    res = run_case(model, cfg, {"shroud": 50.0})
    assert res.status == "done" and res.preload_residual == residual
