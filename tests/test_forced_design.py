"""The friction damper's design curve (``wheelrom study --forced-nonlinear``, issue #45):

- the refined peak of the harmonic balance's curve is the linear wheel's peak found on a
  dense grid of a second implementation (the whole wheel's complex linear system per
  frequency, the 0-peak amplitude of the tip's ellipse) with the contacts off: 1e-6;
- under the elastic law with a preload the force cannot overcome (10 kN against 0.01 N:
  a tangential force of ~300 N at the peak, a Coulomb limit of 4 kN), every contact sticks
  and the refined peak is the stuck wheel's linear peak (tangential springs, no friction
  damping): 1e-3 (measured 8e-5; a preload 1000 times the force's own response puts the
  static terms' rounding, 1e-10 of them, above the harmonics' equations);
- under the paper law the contacts are viscous dampers ``f_s F_n / v_k`` on the micro-slip
  branch: more preload, a smaller peak (monotonic);
- the study stores every case's curve and refined peak as one ``design_point`` of that case
  computes it, names the smallest, draws the design curve, and refuses a resume that drops
  ``--forced-nonlinear``;
- the elastic law's marched hysteresis is periodic: a contact in partial slip walks towards
  its loop over hundreds of periods, and the march goes on until it closes.
"""

import math
import os

import h5py
import numpy as np
import pytest

from wheelrom.analysis import forced
from wheelrom.analysis.forced_peak import resonance
from wheelrom.analysis.periodic import harmonic_balance
from wheelrom.analysis.periodic.forced_wave import ForcedWave, forced_curve
from wheelrom.analysis.stability import linearise
from wheelrom.forces.parameters import force_parameters
from wheelrom.results import study_layout
from wheelrom.studies.forced_nonlinear import design_point


def _ellipse(a: np.ndarray) -> float:
    """0-peak of ``Re(a e^{i t})`` over ``t`` for a complex 3-vector ``a``."""
    return math.sqrt(0.5 * (np.vdot(a, a).real + abs(np.dot(a, a))))


def _linear_peak(model, cfg, K, C, lo: float, hi: float) -> tuple[float, float]:
    """``(frequency [rad/s], amplitude [m])``: blade 0's largest 0-peak tip amplitude on a
    dense grid refined twice about its maximum (direct solves)."""
    F = forced.nozzle_amplitude(model, cfg.wheel.stator_vanes, cfg.excitation.force).ravel()

    def amplitude(w):
        Q = forced.direct_solve(K, C, F, w).reshape(model.blades, -1)
        return _ellipse(model.tip @ Q[0])

    for _ in range(3):
        grid = np.linspace(lo, hi, 201)
        values = [amplitude(w) for w in grid]
        i = int(np.argmax(values))
        lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    return float(grid[i]), float(values[i])


def test_the_refined_peak_is_the_linear_peak(small_model, small_cfg):
    cfg = small_cfg.replace(**{"contacts.tieboss.enabled": False,
                               "contacts.shroud.enabled": False, "flutter.model": "off"})
    K, C = forced.operators(small_model, cfg, contacts=False)
    w0 = resonance(K, small_model, cfg.wheel.stator_vanes)
    grid = w0 * np.linspace(0.99, 1.01, 6)  # no grid point on the resonance
    curve = forced_curve(small_model, force_parameters(small_model, cfg),
                         cfg.wheel.damping_beta, grid, np.zeros((small_model.blades,
                                                                small_model.modes)),
                         harmonics=1, refine=True)
    w, a = _linear_peak(small_model, cfg, K, C, grid[0], grid[-1])
    peak = curve.refined
    assert peak.tip_amplitude > 1.5 * curve.tip_amplitude.max()  # the grid alone misses it
    assert peak.frequency == pytest.approx(w, rel=1e-4)
    assert peak.tip_amplitude == pytest.approx(a, rel=1e-6)


@pytest.mark.parametrize("continuation", ["grid", "arclength"])
def test_a_preload_no_force_overcomes_gives_the_stuck_linear_peak(small_model, small_cfg,
                                                                   continuation):
    """Also traced by arclength: the curve through the lightly damped stuck resonance
    (half-power band 1e-4 of its frequency) reaches the band's end without a fold, and its
    peak found on the curve is the linear one."""
    cfg = small_cfg.replace(**{"contacts.law": "elastic", "flutter.model": "off",
                               "excitation.force": 0.01, "forced.points": 5,
                               "forced.harmonics": 1, "forced.continuation": continuation,
                               "contacts.tieboss.normal_preload": 1e4,
                               "contacts.shroud.normal_preload": 1e4})
    point = design_point(small_model, cfg)
    curve, peak = point.curve, point.curve.refined
    assert curve.converged.all() and (peak.fractions[:, 1] == 1.0).all()  # stuck throughout
    if continuation == "arclength":
        assert curve.trace == "reached the end of the range" and curve.folds.size == 0
        assert curve.frequency[0] == point.band[0] and curve.frequency[-1] == point.band[1]
        assert (np.diff(curve.frequency) > 0).all()  # a linear curve does not turn
    J = linearise(small_model, cfg)[3]
    K, C = forced.operators(small_model, cfg, True, jacobian=J)
    w, a = _linear_peak(small_model, cfg, K, C, *point.band)
    assert peak.frequency == pytest.approx(w, rel=1e-4)
    assert peak.tip_amplitude == pytest.approx(a, rel=1e-3)


def test_the_study_stores_the_design_curve(small_model, small_cfg, tmp_path):
    from mpi4py import MPI

    from wheelrom.plots.figures import plot_file
    from wheelrom.studies.study import run_study

    cfg = small_cfg.replace(**{"flutter.model": "off", "forced.points": 5,
                               "forced.harmonics": 2, "excitation.force": 10.0,
                               "study.grid": {"contacts.shroud.normal_preload":
                                              [100.0, 3000.0, 30000.0]}})
    out = str(tmp_path / "design.h5")
    summary = run_study(cfg, out, MPI.COMM_SELF, mode="stability", log=lambda *_: None,
                        nonlinear=True)
    design = summary["design"]
    peaks = np.array(design["peak_amplitude_m"])
    # the paper law's micro-slip branch: a viscous damper f_s F_n / v_k
    assert (np.diff(peaks) < 0).all() and design["optimum"] == 2
    with h5py.File(out) as f:
        g = f["forced_nonlinear"]
        assert g.attrs["law"] == "paper"  # every case's (a study varying it: "per case")
        assert [s.decode().partition(" ")[0] for s in g["status"][()]] == ["done"] * 3
        one = design_point(small_model, cfg.replace(**{"contacts.shroud.normal_preload":
                                                       3000.0}))
        assert g["peak_amplitude"][1] == pytest.approx(one.curve.refined.tip_amplitude,
                                                       rel=1e-12)
        n = one.curve.frequency.size
        np.testing.assert_allclose(g["tip_amplitude"][1, :n], one.curve.tip_amplitude,
                                   rtol=1e-12)
        assert (g["peak_amplitude"][()] >= np.nanmax(g["tip_amplitude"][()], axis=1)).all()
    why = study_layout.resume_problem(out, cfg, "stability", False, False)
    assert "--forced-nonlinear" in why
    written = plot_file(out, str(tmp_path / "fig"))
    assert any(w.endswith("design_curve.png") for w in written)


def test_a_resumed_study_reads_the_curves_kept_beside_it(small_model, small_cfg, tmp_path,
                                                          capsys):
    """Each finished curve is kept beside the output as it finishes; a study interrupted
    before its file was written, run again with ``--resume``, reads them (here a kept curve
    whose peak was marked: the file holds the mark) and computes the rest (a damaged one
    again, with a warning naming it); the folder goes once the file holds every curve."""
    from mpi4py import MPI

    from wheelrom.studies import design_cases
    from wheelrom.studies.kept_cases import config_digest
    from wheelrom.studies.study import run_study

    cfg = small_cfg.replace(**{"flutter.model": "off", "forced.points": 3,
                               "forced.harmonics": 1, "excitation.force": 10.0,
                               "study.grid": {"contacts.shroud.normal_preload":
                                              [100.0, 3000.0, 30000.0]}})
    out = str(tmp_path / "design.h5")
    folder = design_cases.kept_folder(out)
    cases = [cfg.replace(**{"contacts.shroud.normal_preload": p}) for p in (100.0, 3000.0)]
    kept = design_point(small_model, cases[0])
    kept.curve.refined.tip_amplitude = 1.25e-3  # the mark
    assert design_cases.save_point(folder, 0, cases[0], kept)
    back = design_cases.load_point(folder, 0, cases[0])
    np.testing.assert_array_equal(back.curve.harmonics, kept.curve.harmonics)
    assert back.band == kept.band and back.curve.kinds == kept.curve.kinds
    assert design_cases.load_point(folder, 0, cases[1]) is None  # not its own
    with open(os.path.join(folder.path, "case_1.json"), "w") as f:  # damaged: computed again
        f.write('{"digest": "' + config_digest(cases[1]) + '", "wave"')
    summary = run_study(cfg, out, MPI.COMM_SELF, mode="stability", log=lambda *_: None,
                        nonlinear=True, resume=True)
    peaks = summary["design"]["peak_amplitude_m"]
    assert peaks[0] == 1.25e-3 and peaks[1] < 1e-3 and peaks[2] < 1e-3
    assert "case_1.json: damaged" in capsys.readouterr().err
    assert not os.path.exists(folder.path)


def _plain_march(balance, X, w: float, tolerance: float) -> int:
    """The periods the AFT's march takes from its start to a period that moves no slider by
    more than ``tolerance`` [m], marched one period a call (nothing extrapolated)."""
    q, v = balance.samples(X, w)
    S, K = q.shape[0], len(balance.kinds)
    out = (np.empty((S, 3, balance.modes)), np.empty((S, K)), np.empty((S, K)),
           np.empty((S, K), np.int8))
    sliders = np.empty((S, *balance.forces.slider.shape))
    sliders[0] = balance.forces.sliders_at_rest(np.ascontiguousarray(q.mean(axis=0)))
    for period in range(1, 4001):
        balance.forces.evaluate_samples(q, v, *out, sliders, 1, S, 1, 0.0)
        if np.abs(balance.forces.slider - sliders[0]).max() <= tolerance:
            return period
        sliders[0] = balance.forces.slider
    return 4001


def test_the_march_goes_on_until_the_loop_closes(small_model, small_cfg, monkeypatch):
    """At the stuck resonance's partial slip (the shroud slipping 56 % of the period, the
    tie-boss 9 %) the harmonic forces of the default march equal those of a march of 4000
    periods to 1e-7 of the harmonics' terms (measured 1e-8), where 3 periods were 8.5e-5
    off (the test fails without the march to convergence: Newton's tolerance is 1e-7).

    The walk to the loop is geometric (0.957 a period) and extrapolated: the default march
    closes the loop in 20 periods where the plain march takes 269 (asserted: a quarter), at
    the same forces (the comparison above: a march of 4000 periods extrapolates nothing)."""
    cfg = small_cfg.replace(**{"contacts.law": "elastic", "flutter.model": "off",
                               "excitation.force": 10.0,
                               "contacts.shroud.normal_preload": 3200.0})
    params = force_parameters(small_model, cfg)
    _, q, _, _, _ = linearise(small_model, cfg)
    w = 2 * math.pi * np.array([257.25, 257.0])
    curve = forced_curve(small_model, params, cfg.wheel.damping_beta, w, q, harmonics=3)
    X, w = curve.harmonics[-1], 2 * math.pi * 256.9
    b = ForcedWave(small_model, params, cfg.wheel.damping_beta, 3, 32).balance
    assert curve.converged.all() and 0.3 < curve.fractions[-1, :, 2].max() < 0.9

    def harmonics():
        return (b.P @ b.nonlinear_force(X, w, 1.0))[1:]

    terms = np.abs(b.linear_term(X, w, 1.0))[1:].max()
    marched = harmonics()
    assert b.march_drift <= harmonic_balance.MARCH_TOLERANCE
    accelerated = b.forces.marched_periods
    plain = _plain_march(b, X, w, harmonic_balance.MARCH_TOLERANCE)
    assert plain > 150 and 3 < accelerated < plain / 4
    for name, value in (("MARCH_PERIODS", 4000), ("MARCH_MAX_PERIODS", 4000)):
        monkeypatch.setattr(harmonic_balance, name, value)
    long = harmonics()
    for name, value in (("MARCH_PERIODS", 3), ("MARCH_MAX_PERIODS", 3)):
        monkeypatch.setattr(harmonic_balance, name, value)
    short = harmonics()
    assert np.abs(marched - long).max() < 1e-7 * terms
    assert np.abs(short - long).max() > 1e-5 * terms


def test_the_peaks_made_exact(small_model, small_cfg, tmp_path, capsys):
    """``forced.exact``: each case's refined peak polished by shooting (the same state of the
    transient's equations: the balance at H = 5 within 1 % of it where the contacts stay on
    the micro-slip branch), its largest multiplier stored, printed and kept for a resume."""
    from mpi4py import MPI

    from wheelrom.cli.output import print_study
    from wheelrom.studies import design_cases
    from wheelrom.studies.study import run_study

    cfg = small_cfg.replace(**{"flutter.model": "off", "forced.points": 5,
                               "forced.harmonics": 5, "excitation.force": 10.0,
                               "forced.exact": True,
                               "study.grid": {"contacts.shroud.normal_preload":
                                              [3000.0, 30000.0]}})
    out = str(tmp_path / "design.h5")
    summary = run_study(cfg, out, MPI.COMM_SELF, mode="stability", log=lambda *_: None,
                        nonlinear=True)
    design = summary["design"]
    for hb, exact, mu in zip(design["peak_amplitude_m"], design["exact_tip_amplitude_m"],
                             design["exact_largest_multiplier"], strict=True):
        assert exact is not None and abs(hb - exact) < 0.01 * exact
        assert 0 < mu < 10
    assert design["exact_asked"]
    print_study(summary, out)
    lines = [x for x in capsys.readouterr().out.splitlines() if "(exact " in x]
    assert len(lines) == 2 and "largest |mu|" in lines[0]
    # a shot that did not converge is said, where a study without forced.exact says nothing
    failed = {**design, "exact_tip_amplitude_m": [design["exact_tip_amplitude_m"][0], None]}
    print_study({**summary, "design": failed}, out)
    assert "(exact: the shot did not converge)" in capsys.readouterr().out.splitlines()[-1]
    print_study({**summary, "design": {**failed, "exact_asked": False}}, out)
    assert "(exact" not in capsys.readouterr().out.splitlines()[-1]
    from wheelrom.plots.design import _stable
    from wheelrom.plots.figures import plot_file

    assert any(w.endswith("design_curve.png")  # the exact states beside the balance's line
               for w in plot_file(out, str(tmp_path / "fig")))
    with h5py.File(out) as f:
        g = f["forced_nonlinear"]
        assert list(_stable(design)) == [bool(v) for v in design["exact_stable"]]
        assert (g["exact_multiplier_nd"][()] >= 0).all()
        assert np.isfinite(g["exact_largest_multiplier_at_twice_the_step"][()]).all()
    case = cfg.replace(**{"contacts.shroud.normal_preload": 30000.0})
    point = design_point(small_model, case)
    assert point.exact["tip_amplitude"] == pytest.approx(design["exact_tip_amplitude_m"][1],
                                                         rel=1e-9)
    folder = design_cases.kept_folder(str(tmp_path / "kept.h5"))
    assert design_cases.save_point(folder, 0, case, point)
    assert design_cases.load_point(folder, 0, case).exact == point.exact
