"""The contact laws of the tangential (friction) force, as one record read by every consumer:
the compiled right-hand side of the transient, the reference force model (and through it the
serial reference, the preload, the harmonic balance's AFT and the energy bookkeeping) and the
linearisation about the preloaded equilibrium (docs/theory.md, "Contact laws").

- ``"paper"`` (Table 1, Fig. 4): a friction coefficient of the slip velocity ``v``,
  ``f_s |v| / v_k`` on the micro-slip branch ``|v| <= v_k``, ``f_d + (f_s - f_d)
  exp(-d (|v| - v_k))`` above; force ``-coef F_n v / |v|``.
- ``"elastic"``: the elastic Coulomb contact (a Jenkins slider per contact). A slider ``w``
  (2 components in the contact's ``(xi, zeta)`` plane) is part of the state; the trial force
  ``-k_t (u_t - w)`` on ``A_{s+1}`` is the force while it is at most ``mu F_n`` (stick);
  beyond, the force is ``mu F_n`` along the trial direction and the slider is returned
  radially so that ``|k_t (u_t - w)| = mu F_n`` (slip); an open contact (``F_n = 0``) carries
  no tangential force and its slider follows (``w = u_t``).

The law functions are compiled inline into their callers and branch-free (selects), so the
kernel's contact loop still vectorises. Units: forces [N], displacements [m], velocities
[m/s], stiffness [N/m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from wheelrom.forces.fastmath import fexp

PAPER, ELASTIC = 0, 1
OPEN, STICK, SLIP = 0, 1, 2  # contact states (paper law: STICK is the micro-slip branch)
# a contact's mode held over a piece of a step schedule (the kernel's ``contact_mode``): FREE
# as the law says; the others keep the law on one smooth branch past its switch (an event
# located on an orbit: docs/theory.md "Events in the step"): HELD_OPEN no normal force,
# HELD_STICK and HELD_SLIP closed (the normal spring without its lift-off kink, the
# elastic law's slider stuck or returned whatever the trial force)
FREE, HELD_OPEN, HELD_STICK, HELD_SLIP = 0, 1, 2, 3

#: the packed record compiled code reads: law code, f_s, f_d, decay [s/m], v_k [m/s], mu
L_CODE, L_FS, L_FD, L_DECAY, L_VK, L_MU = range(6)
LAW_SIZE = 6


@dataclass(frozen=True)
class ContactLaw:
    """The tangential law of every contact of a case.

    ``code``: PAPER or ELASTIC; the paper law's ``static`` f_s, ``dynamic`` f_d [-], ``decay``
    d [s/m], ``microslip_velocity`` v_k [m/s]; the elastic law's ``coulomb`` mu [-] (its
    tangential stiffness is per contact and blade: ``ContactParameters.tangential``).
    """

    code: int
    static: float
    dynamic: float
    decay: float
    microslip_velocity: float
    coulomb: float

    @property
    def elastic(self) -> bool:
        return self.code == ELASTIC

    def packed(self) -> np.ndarray:
        """``(LAW_SIZE,)`` the record as compiled code reads it (``L_*`` indices)."""
        return np.array([self.code, self.static, self.dynamic, self.decay,
                         self.microslip_velocity, self.coulomb], dtype=float)


def contact_law(cfg) -> ContactLaw:
    """The law of ``cfg`` (``contacts.law`` and ``[friction]``)."""
    fr = cfg.friction
    return ContactLaw(ELASTIC if cfg.contacts.elastic else PAPER, fr.static, fr.dynamic, fr.decay,
                      fr.microslip_velocity, fr.coulomb)


def mindlin_ratio(poisson: float) -> float:
    """``k_t / k_n = 2 (1 - nu) / (2 - nu)``: Mindlin's ratio of the tangential to the normal
    stiffness of an elastic contact of two bodies of one material (0.82 for nu = 0.3)."""
    return 2.0 * (1.0 - poisson) / (2.0 - poisson)


@numba.njit(inline="always", fastmath={"contract"}, error_model="numpy")
def paper_friction(v_xi, v_zeta, normal, law):
    """``(F_xi, F_zeta, state)``: the paper law's friction force [N] on ``A_{s+1}`` for the
    slip velocity ``(v_xi, v_zeta)`` [m/s] and the normal force ``normal`` [N] (0: open).
    ``v = 0`` gives zero force, the law's limit."""
    f_s, f_d, decay, v_k = law[L_FS], law[L_FD], law[L_DECAY], law[L_VK]
    vt = math.sqrt(v_xi * v_xi + v_zeta * v_zeta)
    micro = vt <= v_k  # micro-slip branch (Fig. 4)
    coef_slip = f_d + (f_s - f_d) * fexp(-decay * (vt - v_k))
    coef = f_s * vt / v_k if micro else coef_slip
    scale = -coef * normal / max(vt, 1e-300)
    state = OPEN if normal <= 0.0 else (STICK if micro else SLIP)
    return scale * v_xi, scale * v_zeta, state


@numba.njit(inline="always", fastmath={"contract"}, error_model="numpy")
def elastic_friction(u_xi, u_zeta, w_xi, w_zeta, normal, k_t, mu, held=FREE):
    """``(F_xi, F_zeta, state, w_xi', w_zeta')``: the elastic Coulomb force [N] on ``A_{s+1}``
    for the tangential relative displacement ``(u_xi, u_zeta)`` [m], the slider ``(w_xi,
    w_zeta)`` [m], the normal force ``normal`` [N] (0: open), tangential stiffness ``k_t``
    [N/m] and Coulomb coefficient ``mu``; and the slider returned onto the Coulomb limit
    (unchanged while the contact sticks, radially returned when it slips, at ``u_t`` when
    open). ``held``: ``HELD_STICK`` / ``HELD_SLIP`` keep it on that branch."""
    trial_xi = -k_t * (u_xi - w_xi)
    trial_zeta = -k_t * (u_zeta - w_zeta)
    size = math.sqrt(trial_xi * trial_xi + trial_zeta * trial_zeta)
    limit = mu * normal
    stuck = size <= limit if held < HELD_STICK else held == HELD_STICK
    scale = 1.0 if stuck else limit / max(size, 1e-300)
    F_xi = scale * trial_xi
    F_zeta = scale * trial_zeta
    # the returned slider: u_t - w' = -F / k_t; a stuck slider keeps its bits
    w_xi_new = w_xi if stuck else u_xi + F_xi / k_t
    w_zeta_new = w_zeta if stuck else u_zeta + F_zeta / k_t
    state = OPEN if normal <= 0.0 else (STICK if stuck else SLIP)
    return F_xi, F_zeta, state, w_xi_new, w_zeta_new


@numba.njit(inline="always", fastmath={"contract"}, error_model="numpy")
def tangential_force(law, u_xi, u_zeta, v_xi, v_zeta, w_xi, w_zeta, normal, k_t, held=FREE):
    """Either law by its record ``law`` (``L_*``): ``(F_xi, F_zeta, state, w_xi', w_zeta')``;
    the paper law leaves the slider as it is (it has none). ``held``: the contact's mode
    (``FREE``, ``HELD_*``; the normal force is the caller's)."""
    if law[L_CODE] == ELASTIC:
        return elastic_friction(u_xi, u_zeta, w_xi, w_zeta, normal, k_t, law[L_MU], held)
    F_xi, F_zeta, state = paper_friction(v_xi, v_zeta, normal, law)
    return F_xi, F_zeta, state, w_xi, w_zeta


def masing_dissipation(amplitude: float, normal: float, k_t: float, mu: float) -> float:
    """Energy [J] one elastic Coulomb contact dissipates per cycle of a straight-line relative
    motion of amplitude ``amplitude`` [m] at constant normal force: ``4 mu F_n (a - mu F_n /
    k_t)`` beyond the stick range ``mu F_n / k_t``, zero within (the Masing loop)."""
    stick = mu * normal / k_t
    return 4.0 * mu * normal * (amplitude - stick) if amplitude > stick else 0.0
