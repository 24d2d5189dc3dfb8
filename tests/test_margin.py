"""Flutter margin (critical Van der Pol intensity) against the full stability pipeline and
against first-order perturbation theory of the undamped wheel modes."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import SMALL
from wheelrom.analysis.margin import case_margin, flutter_margin
from wheelrom.analysis.stability import analyse, blade_blocks, linearise, nd_block


@pytest.mark.parametrize("shroud", [20.0, 80.0])
def test_margin_brackets_the_pipeline_verdict(small_model, small_cfg, shroud):
    """Re-analysed from scratch (equilibrium, Jacobian, spectrum) with mu just below and just
    above the critical value: stable, then unstable."""
    from wheelrom.config import load

    angles = {"tieboss": 45.0, "shroud": shroud}
    res = analyse(small_model, small_cfg, angles, keep_jacobian=True)
    margin = case_margin(small_model, small_cfg, res)
    assert 0 < margin.critical_mu < math.inf
    for factor, verdict in ((0.995, "stable"), (1.005, "unstable")):
        mu = margin.critical_mu * factor
        cfg = load(SMALL, [f"flutter.mu={mu!r}"])
        again = analyse(small_model, cfg, angles)
        assert again.verdict() == verdict, (factor, again.growth_rate.max())
    i = again.critical()
    assert again.nodal_diameter[i] == margin.nodal_diameter
    assert again.frequency_hz[i] == pytest.approx(margin.frequency_hz, rel=1e-3)


def test_margin_without_contacts_is_first_order_perturbation(small_model, small_cfg):
    """Contacts off: the wheel modes are lightly damped by beta K and undamped by the Van der
    Pol matrix V; to first order a mode phi (mass-normalised) of ND k grows at
    ``(mu phi^H V(k) phi - beta omega^2) / 2``, so it crosses at
    ``mu = beta omega^2 / phi^H V(k) phi``: the smallest over all modes is the margin
    (measured difference 7.5e-5: the second-order coupling of close modes through the
    damping matrices; a wrong factor or sign would be off by 100 %)."""
    from wheelrom.analysis.jacobian import van_der_pol_damping
    from wheelrom.config import load

    cfg = load(SMALL, ["contacts.tieboss.enabled=false",
                                  "contacts.shroud.enabled=false"])
    params, q, _, J, _ = linearise(small_model, cfg)
    margin = flutter_margin(params, q, J, rtol=1e-7)
    N, m = q.shape
    V = van_der_pol_damping(dataclasses.replace(params, vdp_mu=1.0), q)
    K = small_model.sparse_stiffness()
    Vrow = blade_blocks(_as_state(V), N, m)[:, m:, m:]
    Krow = blade_blocks(_as_state(K), N, m)[:, m:, :m]
    best = (math.inf, -1)
    for k in range(N // 2 + 1):
        Kk = nd_block(Krow, k)
        w2, phi = np.linalg.eigh((Kk + Kk.conj().T) / 2)
        Vk = nd_block(Vrow, k)
        gain = np.einsum("im,ij,jm->m", phi.conj(), Vk, phi).real
        with np.errstate(divide="ignore"):
            crit = np.where(gain > 0, cfg.wheel.damping_beta * w2 / gain, np.inf)
        if crit.min() < best[0]:
            best = (float(crit.min()), k)
    assert margin.critical_mu == pytest.approx(best[0], rel=1e-3)
    assert margin.nodal_diameter == best[1]


def _as_state(block):
    """``[[0, 0], [block, block]]``: an (N m)-matrix placed where blade_blocks reads the
    ``q''`` rows (columns q for the stiffness, q' for the damping)."""
    import scipy.sparse as sp

    return sp.bmat([[None, sp.csr_matrix(block.shape)], [block, block]], format="csr")


def test_margin_of_a_mistuned_wheel_is_a_named_error(capsys):
    """The margin scans mu over the ND blocks: a mistuned wheel gets a clear refusal that
    names the option and the way to its growth rates, not a traceback."""
    from wheelrom.cli import main as cli

    argv = ["stability", SMALL, "--margin", "--set", "mistuning.alternate=0.01"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "--margin" in err and "tuned wheel" in err and "Traceback" not in err
