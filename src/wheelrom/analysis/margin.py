"""Flutter margin: the smallest Van der Pol intensity ``mu`` at which a case loses stability.

The preloaded equilibrium does not depend on ``mu`` (the Van der Pol force vanishes at rest),
so the Jacobian there is affine in it: ``J(mu) = J_0 + mu J_1`` with
``J_1 = [[0, 0], [0, V]]`` and ``V`` the Van der Pol damping matrix at ``mu`` = 1 N s/m
(:func:`wheelrom.analysis.jacobian.van_der_pol_damping`, linear in ``mu``). For a tuned wheel
both are block-circulant, so per nodal diameter ``k`` the ``2m x 2m`` blocks
``J_0(k) + mu J_1(k)`` give the spectrum at any ``mu`` for the price of one small eigenvalue
problem. The critical intensity ``mu_c`` is found by a scan over ``mu`` in powers of two
(``2^-10 .. 2^10`` times the configured ``mu``: the first unstable point brackets the first
crossing, however the growth rate bends) and bisection on that bracket in ``log mu`` to a
relative ``1e-4``, on the nodal diameters that grow at the bracket's top.

``mu_c / mu`` is the case's flutter margin: how many times stronger the self-excitation may be
before the friction contacts stop holding it down. 0 means unstable without any
self-excitation; ``inf`` that no intensity in the scanned range destabilises the case.

With the aerodynamic table (``flutter.model = "table"``) ``mu`` is the table's factor
``flutter.table_scale`` and ``J_1`` holds the table's whole operator (its stiffness part in
the ``q`` columns too): the margin is the factor on the aerodynamic forces (on the negative
aerodynamic damping of the unstable waves) before the wheel flutters. The equilibrium is
held at the configured factor; only a table with an ND-0 aerodynamic stiffness moves it
(``k_a(0)`` on the uniform static deflection), which the margin then neglects.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from wheelrom.analysis.jacobian import aero_stiffness, van_der_pol_damping
from wheelrom.analysis.stability import blade_blocks, is_circulant, nd_block
from wheelrom.forces.parameters import AERO_TABLE, force_parameters

SCAN = 2.0 ** np.arange(-10, 11)  # the scanned intensities, relative to the configured mu
TOLERANCE = 1e-6  # [1/s] growth rate above which a mode counts as growing (as the verdict)


@dataclass(frozen=True)
class FlutterMargin:
    """``critical_mu`` [N s/m]: the smallest unstable intensity (0: unstable at ``mu = 0``;
    inf: stable over the scan; with ``table`` the smallest unstable factor on the aerodynamic
    table [-]); ``ratio``: ``critical_mu`` over the configured ``mu`` (or table factor);
    ``nodal_diameter``, ``frequency_hz``: the mode that crosses; ``growth_at_zero``
    [1/s]: the largest growth rate without self-excitation (friction and damping only)."""

    critical_mu: float
    ratio: float
    nodal_diameter: int
    frequency_hz: float
    growth_at_zero: float
    table: bool = False  # the aerodynamic table: critical_mu is a factor on it [-]


def _nd_blocks(J: sp.spmatrix, N: int, m: int) -> np.ndarray:
    """``(N//2 + 1, 2m, 2m)`` complex ND blocks of a block-circulant ``J``."""
    row = blade_blocks(J, N, m)
    return np.stack([nd_block(row, k) for k in range(N // 2 + 1)])


def _spectra(blocks0: np.ndarray, blocks1: np.ndarray, mu: float, nds=None):
    """``(nds, eigenvalues (K, 2m))`` of ``J_0 + mu J_1`` at the nodal diameters ``nds``
    (None: all)."""
    nds = np.arange(len(blocks0)) if nds is None else np.asarray(nds)
    return nds, np.linalg.eigvals(blocks0[nds] + mu * blocks1[nds])


def _fastest(blocks0: np.ndarray, blocks1: np.ndarray, mu: float, nds=None):
    """``(growth [1/s], nd, frequency [Hz])`` of the fastest mode of ``J_0 + mu J_1`` over the
    nodal diameters ``nds`` (None: all)."""
    nds, lam = _spectra(blocks0, blocks1, mu, nds)
    k, i = np.unravel_index(int(np.argmax(lam.real)), lam.shape)
    return float(lam.real[k, i]), int(nds[k]), abs(float(lam.imag[k, i])) / (2 * math.pi)


def _growing(blocks0: np.ndarray, blocks1: np.ndarray, mu: float, nds=None) -> np.ndarray:
    """The nodal diameters among ``nds`` (None: all) with a growing mode at ``mu``."""
    nds, lam = _spectra(blocks0, blocks1, mu, nds)
    return nds[lam.real.max(axis=1) > TOLERANCE]


def case_margin(model, cfg, result) -> FlutterMargin:
    """The flutter margin of a case analysed with ``keep_jacobian``
    (:func:`wheelrom.analysis.stability.analyse`): its Jacobian and equilibrium reused."""
    params = force_parameters(model, cfg, result.angles_deg)
    return flutter_margin(params, result.equilibrium, result.jacobian)


def flutter_margin(params, q: np.ndarray, J: sp.spmatrix, rtol: float = 1e-4) -> FlutterMargin:
    """The flutter margin of a linearised case (:func:`wheelrom.analysis.stability.linearise`:
    its force parameters, equilibrium ``q`` ``(N, m)`` and Jacobian ``J``)."""
    N, m = q.shape
    mu = params.vdp_mu
    table = params.vdp_model == AERO_TABLE
    unit = dataclasses.replace(params, vdp_mu=1.0)
    zero = sp.csr_matrix((N * m, N * m))
    J1 = sp.bmat([[zero, zero], [aero_stiffness(unit, N, m), van_der_pol_damping(unit, q)]],
                 format="csr")
    J0 = (sp.csr_matrix(J) - mu * J1).tocsr()
    if not (is_circulant(J0, N, m) and is_circulant(J1, N, m)):
        raise ValueError("the flutter margin needs a cyclic (tuned) wheel")
    blocks0, blocks1 = _nd_blocks(J0, N, m), _nd_blocks(J1, N, m)
    at_zero = _fastest(blocks0, blocks1, 0.0)
    if at_zero[0] > TOLERANCE:
        return FlutterMargin(0.0, 0.0, at_zero[1], at_zero[2], at_zero[0], table)
    reference = mu if mu > 0 else 1.0
    low = 0.0
    for factor in SCAN:
        high = reference * factor
        if _fastest(blocks0, blocks1, high)[0] > TOLERANCE:
            break
        low = high
    else:
        return FlutterMargin(math.inf, math.inf, -1, math.nan, at_zero[0], table)
    while low == 0.0:  # unstable at the scan's first point: halve until stable
        if _fastest(blocks0, blocks1, high / 2)[0] <= TOLERANCE or high < 1e-9 * reference:
            low = high / 2
        else:
            high /= 2
    # the bisection watches the nodal diameters that grow at the bracket's top, narrowed as
    # the top comes down: one that is stable there and at the bottom does not cross in
    # between at the scan's resolution (the scan's own premise); at a factor 2 above the
    # crossing 24 of 34 grow on the paper's wheel, a few halvings later one or two
    crossing = _growing(blocks0, blocks1, high)
    while high / low - 1 > rtol:
        middle = math.sqrt(low * high)
        growing = _growing(blocks0, blocks1, middle, crossing)
        if growing.size:
            high, crossing = middle, growing
        else:
            low = middle
    _, nd, hz = _fastest(blocks0, blocks1, high, crossing)  # the mode that has just crossed
    return FlutterMargin(high, high / reference, nd, hz, at_zero[0], table)
