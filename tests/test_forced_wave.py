"""The nonlinear forced response by harmonic balance (:mod:`wheelrom.analysis.periodic.
forced_wave`, issue #45) against the linear forced response (:mod:`wheelrom.analysis.forced`,
a second implementation: the whole wheel's complex linear system per frequency):

- contacts off, no self-excitation: the balance is linear and its harmonic 1 on blade 0
  equals the linear response of blade 0 to 1e-6 at every frequency (the travelling-wave
  condition and the nozzle's phases are right);
- a force small enough that the contacts stay linear: under the elastic law every contact
  sticks and the response is the stuck wheel's (tangential springs, no friction damping);
  under the paper law the contacts stay on the micro-slip branch, the linearised damper
  ``f_s F_n / v_k``: 1e-6, and the contacts' shares say stuck (micro-slip).
"""

import math

import numpy as np
import pytest

from wheelrom.analysis import forced
from wheelrom.analysis.periodic.forced_wave import forced_curve
from wheelrom.analysis.stability import linearise
from wheelrom.forces.contact_law import STICK
from wheelrom.forces.parameters import force_parameters

FREQUENCIES_HZ = np.array([150.0, 300.0, 450.0, 480.0, 495.0])


def _harmonic_1(curve) -> np.ndarray:
    """``(F, m)`` complex harmonic 1 of blade 0."""
    return curve.harmonics[:, 1] + 1j * curve.harmonics[:, 2]


def test_without_contacts_it_is_the_linear_forced_response(small_model, small_cfg):
    cfg = small_cfg.replace(**{"contacts.tieboss.enabled": False,
                               "contacts.shroud.enabled": False, "flutter.model": "off"})
    w = 2 * math.pi * FREQUENCIES_HZ
    params = force_parameters(small_model, cfg)
    curve = forced_curve(small_model, params, cfg.wheel.damping_beta, w,
                         np.zeros((small_model.blades, small_model.modes)), harmonics=3)
    assert curve.converged.all() and curve.wave == cfg.wheel.stator_vanes % small_model.blades
    K, C = forced.operators(small_model, cfg, contacts=False)
    F = forced.nozzle_amplitude(small_model, cfg.wheel.stator_vanes, cfg.excitation.force)
    for i, wi in enumerate(w):
        Q = forced.direct_solve(K, C, F.ravel(), wi).reshape(small_model.blades, -1)
        np.testing.assert_allclose(_harmonic_1(curve)[i], Q[0], rtol=1e-6,
                                   atol=1e-6 * np.abs(Q[0]).max())
        # the higher harmonics of a linear wheel are zero
        assert np.abs(curve.harmonics[i, 3:]).max() < 1e-9 * np.abs(Q[0]).max()


# the paper law's friction is bilinear (F_n(t) v(t)): linear to 1e-6 at 0.1 N; the stuck
# elastic contact is linear but for the arm's geometry, and its force noise (the kinematics'
# rounding) needs a response well above it: 1 N
@pytest.mark.parametrize(("law", "force"), [("paper", 0.1), ("elastic", 1.0)])
@pytest.mark.parametrize("angle", [30.0, 50.0])
def test_small_forcing_is_the_linearised_response(small_model, small_cfg, angle, law, force):
    cfg = small_cfg.replace(**{"contacts.law": law, "flutter.model": "off",
                               "excitation.force": force})
    angles = {"shroud": angle}
    _, q, _, J, _ = linearise(small_model, cfg, angles)  # the equilibrium (nozzle off)
    params = force_parameters(small_model, cfg, angles)  # with the nozzle
    w = 2 * math.pi * FREQUENCIES_HZ
    curve = forced_curve(small_model, params, cfg.wheel.damping_beta, w, q, harmonics=3)
    assert curve.converged.all()
    assert (curve.fractions[:, :, STICK] == 1.0).all()  # stuck / on the micro-slip branch
    K, C = forced.operators(small_model, cfg, True, angles, jacobian=J)
    F = forced.nozzle_amplitude(small_model, cfg.wheel.stator_vanes, cfg.excitation.force)
    for i, wi in enumerate(w):
        Q = forced.direct_solve(K, C, F.ravel(), wi).reshape(small_model.blades, -1)
        np.testing.assert_allclose(_harmonic_1(curve)[i], Q[0], rtol=1e-6,
                                   atol=1e-6 * np.abs(Q[0]).max())


def test_the_command_sets_the_friction_limited_peak_beside_the_linear_one(capsys):
    """``forced-response --nonlinear`` under the elastic law on the small wheel: the stuck
    linearised peak is a lightly damped 0.74 mm; the contacts slip at it and hold the
    nonlinear response an order of magnitude lower (measured 24 um, the contacts slipping
    part of the period). Newton solves 4 of the 8 frequencies since the AFT marches the
    sliders to their periodic loop (7 of 8 on the loop of 3 periods, which is not periodic
    in partial slip: tests/test_forced_design.py); the friction-limited peak at the stuck
    resonance is where it fails (docs/theory.md, "The friction damper's design curve")."""
    import json

    from conftest import SMALL
    from wheelrom.cli import main as cli

    argv = ["forced-response", SMALL, "--set", "contacts.law=elastic", "--nonlinear",
            "--frequencies", "252:259:8", "--json"]
    assert cli.main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    nl = out["nonlinear"]
    assert nl["law"] == "elastic" and len(nl["tip_amplitude_m"]) == 8
    assert sum(nl["converged"]) >= 4
    assert nl["peak_amplitude_m"] < 0.2 * max(out["max_amplitude_m"])
    assert max(s["slip"] for s in nl["peak_shares"].values()) > 0.1


def test_the_curve_is_written_and_read_back(tmp_path, capsys):
    """``--out`` keeps the nonlinear curve in ``/nonlinear`` (covered by the file's
    checksums), ``info`` names it. (180-190 Hz: between the slipping and the stuck resonance,
    the contacts slip and open there; 0.5 s of balance against 25 s in the stuck peak's
    partial slip, which other tests solve.)"""
    import h5py

    from conftest import SMALL
    from wheelrom.cli import main as cli

    path = tmp_path / "f.h5"
    argv = ["forced-response", SMALL, "--set", "contacts.law=elastic", "--nonlinear",
            "--frequencies", "180:190:4", "--harmonics", "3", "--out", str(path)]
    assert cli.main(argv) == 0
    with h5py.File(path, "r") as f:
        g = f["nonlinear"]
        assert g.attrs["law"] == "elastic" and g["harmonics"].shape[:2] == (4, 7)
        assert g["contact_shares"].shape == (4, 2, 3)
        converged = g["converged"][()]
        assert np.isfinite(g["tip_amplitude"][()][converged]).all()
    capsys.readouterr()
    assert cli.main(["info", str(path), "--verify"]) == 0
    text = capsys.readouterr().out
    assert "nonlinear:     harmonic balance, H = 3, contacts.law = 'elastic'" in text
    assert cli.main(["plot", str(path), "--outdir", str(tmp_path / "fig")]) == 0
    assert (tmp_path / "fig" / "forced_response.png").stat().st_size > 1000
    with h5py.File(path, "r+") as f:  # a changed value of the curve is found
        f["nonlinear/tip_amplitude"][0] = 1.0
    assert cli.main(["info", str(path), "--verify"]) == 1


@pytest.mark.parametrize(("extra", "message"), [
    (["--set", "excitation.force=0.0"], "excitation.force = 0: the nozzle force is off"),
    (["--harmonics", "0"], "--harmonics 0: must be >= 1"),
])
def test_the_command_refuses_in_one_line(extra, message, capsys, tmp_path, monkeypatch):
    from conftest import SMALL
    from wheelrom.cli import main as cli

    monkeypatch.chdir(tmp_path)
    argv = ["forced-response", SMALL, "--nonlinear", "--frequencies", "250:259:3", *extra]
    assert cli.main(argv) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x.h5").exists()


def test_a_range_without_a_resonance_says_so(capsys):
    """10..20 Hz holds neither the slipping (120 Hz) nor the stuck (257 Hz) ND 2 resonance of
    the small wheel: the command says so in one line (and in --json), and computes the
    off-resonance response all the same; 110..130 Hz holds the slipping one: no such line."""
    import json

    from conftest import SMALL
    from wheelrom.cli import main as cli

    args = ["forced-response", SMALL, "--nonlinear", "--harmonics", "1", "--json",
            "--set", 'contacts.law="elastic"']
    assert cli.main([*args, "--frequencies", "10:20:3"]) == 0
    out = json.loads(capsys.readouterr().out)
    said = out["nonlinear"]["no_resonance"]
    assert said.startswith("no resonance in 10..20 Hz: the ND 2 family 0 resonates with the "
                           "contacts slipping 120"), said
    assert "stuck 256" in said and all(out["nonlinear"]["converged"])
    assert cli.main([*args, "--frequencies", "110:130:3"]) == 0
    assert "no_resonance" not in json.loads(capsys.readouterr().out)["nonlinear"]


def test_the_command_traces_the_curve_on_request(tmp_path, capsys):
    """``forced.continuation = "arclength"``: ``forced-response --nonlinear`` also traces the
    curve over the grid's range (paper law, small wheel): JSON ``traced`` with the points in
    order, the folds, Hill's growth per point and the refined peak (at least the grid's
    largest), the same in ``/nonlinear/traced``."""
    import json

    import h5py

    from conftest import SMALL
    from wheelrom.cli import main as cli

    path = tmp_path / "f.h5"
    argv = ["forced-response", SMALL, "--nonlinear", "--frequencies", "110:130:5",
            "--harmonics", "2", "--set", 'forced.continuation="arclength"', "--json",
            "--out", str(path)]
    assert cli.main(argv) == 0
    nl = json.loads(capsys.readouterr().out)["nonlinear"]
    tr = nl["traced"]
    assert tr["end"].startswith("reached the end of the range")
    hz = [f for f in tr["frequency_hz"] if f is not None]
    assert hz[0] == pytest.approx(110.0) and hz[-1] == pytest.approx(130.0) and len(hz) > 5
    assert len(tr["growth_per_s"]) == len(tr["frequency_hz"])
    assert all(g is not None for g in tr["growth_per_s"])  # the paper law: Hill's method
    assert tr["peak_amplitude_m"] >= max(a for a in nl["tip_amplitude_m"] if a) * (1 - 1e-9)
    with h5py.File(path) as f:
        t = f["nonlinear/traced"]
        assert t["frequency_hz"].shape == (len(tr["frequency_hz"]),)
        assert t.attrs["peak_amplitude_m"] == tr["peak_amplitude_m"]
    capsys.readouterr()
    assert cli.main(["plot", str(path), "--outdir", str(tmp_path / "fig")]) == 0
    assert (tmp_path / "fig" / "forced_response.png").stat().st_size > 1000


def test_without_a_band_the_nonlinear_response_spans_slipping_to_stuck(capsys):
    """Issue #74, 1: ``--nonlinear`` without ``--frequencies`` searches the band from the
    excited ND's resonance with the contacts slipping (120.0 Hz on the small wheel) to the one
    with them stuck (the linear peak, 256.6 Hz) +-3 %, not the stuck one's +-1 %: the
    nonlinear resonance, at the default 10 N with the contacts slipping grossly, is inside it,
    at the slipping one. Over 125..200 Hz, above it, the largest value lies on the band's
    lower edge and is said so, never called a peak, and the line on the missing linear
    resonances says where the nonlinear response's largest value is."""
    import json

    from conftest import SMALL
    from wheelrom.cli import main as cli

    args = ["forced-response", SMALL, "--nonlinear", "--harmonics", "1",
            "--set", 'contacts.law="elastic"']
    assert cli.main([*args, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    lo, hi = out["band_hz"]
    assert hi == pytest.approx(1.03 * out["peak_frequency_hz"], rel=1e-3)  # the stuck one
    assert lo == pytest.approx(0.97 * 120.02, rel=1e-3)  # the slipping one
    nl = out["nonlinear"]
    assert "peak_at_edge" not in nl and "no_resonance" not in nl
    assert lo < nl["peak_frequency_hz"] < 1.05 * 120.02  # at the slipping resonance
    assert nl["peak_amplitude_m"] == max(a for a in nl["tip_amplitude_m"] if a is not None)
    # the refined peak: a maximum of the solved curve between the grid neighbours of its
    # largest point, at least that point's amplitude
    f = out["frequency_hz"]
    i = f.index(nl["peak_frequency_hz"])
    assert f[i - 1] < nl["refined_peak_frequency_hz"] < f[i + 1]
    assert nl["refined_peak_amplitude_m"] >= nl["peak_amplitude_m"]
    assert cli.main([*args, "--json", "--frequencies", "125:200:5"]) == 0
    nl = json.loads(capsys.readouterr().out)["nonlinear"]
    assert nl["peak_at_edge"] == "lower" and "refined_peak_amplitude_m" not in nl
    assert nl["peak_frequency_hz"] == pytest.approx(125.0, rel=1e-12)
    assert nl["no_resonance"].endswith("the linear response computed here is off resonance; "
                                       "the nonlinear response's largest value is at the "
                                       "band's lower edge")
    assert cli.main([*args, "--frequencies", "125:200:5"]) == 0
    assert "nonlinear largest value at the band's lower edge (the resonance lies below it" \
        in capsys.readouterr().out


def test_the_friction_plateau_is_solved_at_every_frequency(capsys):
    """Issue #69: the small wheel under stiff, rough contacts (``k_t`` 7.6e7 N/m, Coulomb 0.6)
    at 0.02 N, shroud 45 deg, swept through its stuck resonance (2.83 um at 258.009 Hz): where
    the stuck response would pass the contacts' slip onset they slip and hold a friction
    plateau. Every one of the 41 frequencies is solved (9 holes over the plateau before the
    slow flow's relaxation), the plateau is flat (1.130-1.137 um: within 1 % over 257.99-258.03
    Hz, where the stuck response would reach 1.2-2.8 um), and off it the contacts stick and
    the curve is the linear (stuck) response, a second computation, to 1e-3."""
    import json

    from conftest import SMALL
    from wheelrom.cli import main as cli

    keys = ['contacts.law="elastic"', "contacts.tieboss.tangential_stiffness=7.6e7",
            "contacts.shroud.tangential_stiffness=7.6e7", "friction.coulomb=0.6",
            "excitation.force=0.02", 'flutter.model="off"']
    argv = ["forced-response", SMALL, *[a for k in keys for a in ("--set", k)],
            "--angle", "shroud", "45", "--frequencies", "257.90:258.10:41", "--nonlinear",
            "--harmonics", "3", "--json"]
    assert cli.main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    nl = out["nonlinear"]
    assert all(nl["converged"]), nl["converged"]
    f = np.array(out["frequency_hz"])
    linear, curve = np.array(out["max_amplitude_m"]), np.array(nl["tip_amplitude_m"])
    plateau = (f >= 257.99 - 1e-9) & (f <= 258.03 + 1e-9)
    assert curve[plateau].max() / curve[plateau].min() < 1.01
    assert np.all(curve[plateau] < 0.95 * linear[plateau])  # held below the stuck response
    stuck = curve < 0.9 * curve[plateau].min()  # far below the slip onset: the contacts stick
    assert stuck.sum() >= 25
    np.testing.assert_allclose(curve[stuck], linear[stuck], rtol=1e-3)


def test_the_friction_plateau_is_traced_by_arclength_without_a_stall(capsys):
    """Issue #69: the same case traced by arclength. Over the plateau the balance's residual
    has a kink at every step (a sample's contact starts or stops sticking) and the corrector
    stalled at the slip onset ("stalled at 257.99 Hz"), the plateau only bridged by jumps
    of the grid's spacing. The trace now reaches both ends of the range without a stall,
    and its points at the plateau's level sample the whole plateau (every 0.01 Hz of
    257.99-258.03 Hz), each within 1 % of the grid's plateau, a second computation by
    natural continuation and the slow flow's relaxation."""
    import json

    from conftest import SMALL
    from wheelrom.cli import main as cli

    keys = ['contacts.law="elastic"', "contacts.tieboss.tangential_stiffness=7.6e7",
            "contacts.shroud.tangential_stiffness=7.6e7", "friction.coulomb=0.6",
            "excitation.force=0.02", 'flutter.model="off"', 'forced.continuation="arclength"']
    argv = ["forced-response", SMALL, *[a for k in keys for a in ("--set", k)],
            "--angle", "shroud", "45", "--frequencies", "257.90:258.10:41", "--nonlinear",
            "--harmonics", "3", "--json"]
    assert cli.main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    nl, traced = out["nonlinear"], out["nonlinear"]["traced"]
    assert "stalled" not in traced["end"], traced["end"]
    f = np.array(out["frequency_hz"])
    grid = np.array(nl["tip_amplitude_m"])[(f >= 257.99 - 1e-9) & (f <= 258.03 + 1e-9)]
    points = [(w, a) for w, a in zip(traced["frequency_hz"], traced["tip_amplitude_m"],
                                     strict=True) if w is not None]
    w, a = np.array(points).T
    on = (a > 0.98 * grid.min()) & (w >= 257.99) & (w <= 258.03)
    assert np.all(a[on] <= 1.01 * grid.max()) and np.all(a[on] >= 0.99 * grid.min())
    bins = np.floor((w[on] - 257.99) / 0.01).astype(int)
    assert set(bins) >= {0, 1, 2, 3}, sorted(set(bins))
