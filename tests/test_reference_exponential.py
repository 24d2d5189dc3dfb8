"""The serial reference of the exponential scheme (numpy/scipy ETDRK4, a second implementation
of the compiled step) against the compiled TS and against closed forms; ``compare`` picks the
reference of the configured scheme and fails on a non-finite difference; the options a TS
records are those that took effect (issue #40, defects 5 and 9)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import SMALL
from wheelrom.cli import main as cli
from wheelrom.runtime.kernel_cache import COMPILING_MESSAGE
from wheelrom.transient import reference
from wheelrom.transient.reference import etdrk4_step, reference_solution, segment_propagators
from wheelrom.transient.run import run_case
from wheelrom.transient.ts import PREFIX, scoped_options, ts_settings

EXPONENTIAL = ['time.scheme="exponential"', "time.step=1e-5"]


@pytest.fixture(scope="module")
def attachment(small_cfg, comm):
    """The small wheel on the default (attachment) basis and the default scheme at 10 us."""
    from wheelrom.rom.build import build_model

    cfg = small_cfg.replace(**{"wheel.basis": "attachment", "time.scheme": "exponential",
                               "time.step": 1e-5})
    return build_model(cfg, comm), cfg


def test_reference_equals_the_compiled_ts_from_the_preload(attachment):
    """300 steps of 10 us from the preloaded equilibrium with a 1 um seed, contacts, nozzle
    and Van der Pol on: the numpy ETDRK4 and the compiled TS agree to 1e-9 in the motion and
    in the four works (the W treatment: classical RK4 weights, the damping power with the
    whole K_R). The RK 3bs reference, a different scheme, does not: the check can fail."""
    model, cfg = attachment
    steps, h = 300, 1e-5
    cfg = cfg.replace(**{"time.start": "preload", "time.perturbation": 1e-6,
                         "time.end": steps * h, "time.window": steps * h})
    res = run_case(model, cfg)
    assert res.status == "done" and res.steps == steps
    assert res.options["ts_scheme"] == "etdrk4" and res.options["ts_dt"] == h
    _, states, _ = reference_solution(model, cfg, steps, h, sample_every=steps,
                                      scheme="exponential")
    n2 = 2 * model.size
    ref, got = states[-1], res.final_state
    assert np.abs(ref[:n2]).max() > 0 and np.all(np.abs(ref[n2:]) > 0)
    assert np.abs(got[:n2] - ref[:n2]).max() <= 1e-9 * np.abs(ref[:n2]).max()
    assert np.abs(got[n2:] - ref[n2:]).max() <= 1e-9 * np.abs(ref[n2:]).max()
    with np.errstate(all="ignore"):  # RK 3bs is not stable at 10 us on this basis
        _, rk, _ = reference_solution(model, cfg, steps, h, sample_every=steps, scheme="rk")
        assert not np.abs(got[:n2] - rk[-1][:n2]).max() <= 1e-9 * np.abs(ref[:n2]).max()


def _block(seed: int = 0):
    """A non-diagonal 2 x 2 segment block: a 60 kHz and a 500 Hz mode in a rotated basis."""
    w = 2 * np.pi * np.array([6.0e4, 5.0e2])
    angle = 0.3 + seed
    R = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    return R @ np.diag(w**2) @ R.T


@pytest.mark.parametrize("beta", [0.0, 2e-6])
def test_linear_block_is_the_analytic_oscillator(beta):
    """Two blades of one linear block ``q'' + beta A0 q' + A0 q = F`` (constant ``F``, the
    explicit part), 60 kHz and 500 Hz modes mixed by a rotation, 3.3 rad per step for the
    stiff one: 37 steps against the closed form per eigenmode (cos/sin/exp, static
    deflection ``F / a``), to round-off; the work rows ``W' = (t^3, 1, 0, 0)`` by the RK4
    weights (exact for a cubic: ``t^4 / 4``)."""
    A0 = _block()
    blades, m, h, steps = 2, 2, 1.75e-5 / 2, 37
    a, P = np.linalg.eigh(A0)
    rng = np.random.default_rng(1)
    q0, v0 = rng.standard_normal((blades, m)) * 1e-4, rng.standard_normal((blades, m)) * 1e-1
    F = rng.standard_normal((blades, m)) * 1e4
    n = blades * m

    def explicit(t, u):
        out = np.zeros_like(u)
        out[n : 2 * n] = F.ravel()
        out[2 * n :] = (t**3, 1.0, 0.0, 0.0)
        return out

    prop = segment_propagators(A0, beta, h)
    u = np.concatenate([q0.ravel(), v0.ravel(), np.zeros(4)])
    for i in range(steps):
        u = etdrk4_step(explicit, i * h, u, h, prop, blades)
    t = steps * h
    z0, y0, f = q0 @ P, v0 @ P, F @ P  # eigen-coordinates: z'' + beta a z' + a z = f
    static = f / a
    sigma = beta * a / 2
    wd = np.sqrt(a - sigma**2)
    decay, c, s = np.exp(-sigma * t), np.cos(wd * t), np.sin(wd * t)
    x0 = z0 - static
    z = static + decay * (x0 * (c + sigma * s / wd) + y0 * s / wd)
    y = decay * (y0 * (c - sigma * s / wd) - x0 * a * s / wd)
    got_z = u[:n].reshape(blades, m) @ P
    got_y = u[n : 2 * n].reshape(blades, m) @ P
    assert np.abs(got_z - z).max() <= 1e-12 * np.abs(z).max()
    assert np.abs(got_y - y).max() <= 1e-12 * np.abs(y).max()
    assert u[2 * n] == pytest.approx(t**4 / 4, rel=1e-13)
    assert u[2 * n + 1] == pytest.approx(t, rel=1e-13)


def test_compare_uses_the_configured_scheme_and_agrees(capsys):
    """The default scheme: the exponential reference, agreeing to 1e-9 (with the RK 3bs
    reference of before, 3e-4)."""
    args = ["compare", SMALL, "--steps", "100", "--json"]
    for item in EXPONENTIAL:
        args += ["--set", item]
    assert cli.main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["scheme"] == "exponential" and out["step_s"] == 1e-5
    assert 0 <= out["max_relative_difference"] <= 1e-9


def test_compare_exits_nonzero_on_a_non_finite_difference(monkeypatch, capsys):
    """A reference that diverged (NaN state) is no agreement: status 1, one line on stderr;
    the reference is asked for the configured scheme (rk here)."""
    schemes = []
    real = reference.reference_solution

    def diverged(model, cfg, steps, step, **kw):
        schemes.append(kw.get("scheme"))
        times, states, wall = real(model, cfg, 1, step, **{**kw, "sample_every": 1})
        return times, np.full_like(states, np.nan), wall

    monkeypatch.setattr(reference, "reference_solution", diverged)
    assert cli.main(["compare", SMALL, "--steps", "3", "--json"]) == 1
    captured = capsys.readouterr()
    assert json.loads(captured.out)["max_relative_difference"] is None
    # besides the first-run line of a process that compiles a kernel (whether it does depends
    # on what ran before it, and on a fresh machine on how far the other test worker got)
    err = [ln for ln in captured.err.strip().splitlines() if ln != COMPILING_MESSAGE]
    assert schemes == ["rk"]
    assert len(err) == 1 and "not finite" in err[0] and err[0].startswith("wheelrom: compare")


def test_recorded_options_are_those_that_took_effect(small_model, small_cfg):
    """-wheel_ts_rk_type 5dp and -wheel_ts_adapt_type basic with the exponential scheme (a
    TS of type python with its own fixed step) are not recorded, the step stays fixed and
    both are left unread (reported unused at the end of a command); with time.scheme = "rk"
    the same options act and are recorded."""
    from wheelrom.transient.options import unused

    options = {"ts_rk_type": "5dp", "ts_adapt_type": "basic"}
    exp = small_cfg.replace(**{"time.scheme": "exponential", "time.step": 1e-5,
                               "time.end": 2e-4, "time.window": 1e-4})
    res = run_case(small_model, exp, options=options)
    assert res.status == "done" and res.steps == 20  # fixed steps: no adaptor acted
    res = res.options
    assert res["ts_scheme"] == "etdrk4"
    assert "ts_rk_type" not in res and res["ts_adapt_type"] == "none"
    assert ts_settings(exp, options=options) == res
    with scoped_options(PREFIX, options):  # as after --: in the database for the command
        ts_settings(exp)
        left = unused(["-wheel_ts_rk_type", "5dp", "-wheel_ts_adapt_type", "basic"])
        assert sorted(left) == ["wheel_ts_adapt_type", "wheel_ts_rk_type"]
    rk = ts_settings(small_cfg, options=options)
    assert rk["ts_type"] == "rk" and rk["ts_rk_type"] == "5dp"
    assert rk["ts_adapt_type"] == "basic"


def test_compare_under_the_elastic_law_takes_the_stable_step(capsys):
    """Elastic law on the attachment wheel at 15 us: the TS lowers its step to the scheme's
    stability for the stuck contacts (10.935 us, the stuck springs' share propagated
    exactly) and the serial reference takes the same one, propagating the same share;
    they agree to 1e-9."""
    args = ["compare", SMALL, "--steps", "100", "--json"]
    for item in [*EXPONENTIAL, "time.step=1.5e-5", "contacts.law=elastic",
                 'wheel.basis="attachment"']:
        args += ["--set", item]
    assert cli.main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["scheme"] == "exponential"
    assert out["step_s"] == pytest.approx(1.5e-5 * 0.9**3, rel=1e-9)
    assert 0 <= out["max_relative_difference"] <= 1e-9
