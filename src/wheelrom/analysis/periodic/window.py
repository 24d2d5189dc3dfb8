"""The harmonic balance's three-blade window: blade 0 and both neighbours, whose forces on
blade 0 are the whole tuned wheel's (:mod:`wheelrom.analysis.periodic.harmonic_balance`), the
physical inputs of those forces and their sample-local derivatives' record.

Blades of the window: 0, +1, -1 (as window blades 0, 1, 2). Units: modal coordinates
[sqrt(kg) m], displacements [m], forces [N].
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from wheelrom.forces.parameters import AERO_TABLE, VDP_OFF, ForceParameters

WINDOW = (0, 1, -1)  # the window's blades: blade 0, the next, the previous
#: finite-difference step of the force Jacobian: this physical displacement [m] at the point of
#: a modal coordinate that moves most (contacts or tip)
FD_DISPLACEMENT = 1e-10
#: condition number of a blade's physical-input rows above which the force Jacobian is
#: differenced over the modal coordinates instead (:func:`force_inputs`)
MAX_INPUT_CONDITION = 1e8


def window_parameters(params: ForceParameters) -> ForceParameters:
    """``params`` on a three-blade window (blade 0, +1, -1 as blades 0, 1, 2): the cyclic
    kernel then gives blade 0 exactly the forces it has in the whole wheel (its contacts with
    both neighbours, the relative Van der Pol force of both differences). The pair (1, 2) of
    the window is spurious and acts on the neighbours only. The nozzle is off (the autonomous
    problem) and an aerodynamic table is applied per harmonic instead (it couples every blade)."""
    N = params.blades
    pick = np.array([0, 1, N - 1])
    c = params.contacts
    contacts = dataclasses.replace(
        c, frame=np.ascontiguousarray(c.frame[:, pick]),
        stiffness=np.ascontiguousarray(c.stiffness[:, pick]),
        angles_deg={k: np.asarray(v)[pick] for k, v in c.angles_deg.items()})
    return dataclasses.replace(
        params, blades=3, nozzle_force=0.0, nozzle_phase=np.zeros(3),
        vdp_model=VDP_OFF if params.vdp_model == AERO_TABLE else params.vdp_model,
        aero_displacement=np.zeros(3), aero_velocity=np.zeros(3), contacts=contacts)


def wave_state(c: np.ndarray, wave: int, blades: int, omega: float, tau: float = 0.0):
    """``(q, v)`` ``(N, m)`` of every blade of travelling wave ``wave`` at phase ``tau`` [rad]
    from blade 0's complex harmonics ``c`` ``(H + 1, m)`` [sqrt(kg) m] (``c_0`` the mean),
    ``omega`` [rad/s]: blade ``s`` is blade 0 at ``tau + s 2 pi k / N``."""
    h = np.arange(c.shape[0])
    phase = tau + np.arange(blades) * 2 * math.pi * (wave % blades) / blades
    rotor = np.exp(1j * np.outer(phase, h))  # (N, H + 1)
    return (rotor @ c).real, omega * ((rotor * (1j * h)) @ c).real


def force_inputs(params: ForceParameters):
    """``(blades (n,), rows (n, m), directions (n, m))``: the physical inputs of the force on
    window blade 0 (rows ``r_i``: ``u_i = r_i . q`` of window blade ``blades[i]``) and modal
    directions ``d_i`` that move input ``i`` alone (``r_j . d_i = delta_ij`` per blade); None
    when a blade's rows are dependent (fewer modes than inputs): the modal differencing then.

    Blade 0 feels its contacts with both neighbours (its own points A and B of every kind, the
    next blade's A, the previous blade's A and B: the arm geometry) and the Van der Pol force
    of its displacement ``y = aero . q`` and both neighbours'. The window's spurious pair
    (1, 2) acts on the neighbours only, so the next blade's B is not an input."""
    c = params.contacts
    A = [np.asarray(a) for a in c.shape_A]  # (3, m) per kind
    B = [np.asarray(b) for b in c.shape_B]
    y = np.asarray(params.aero)[None]
    per_blade = [np.vstack(A + B + [y]), np.vstack(A + [y]), np.vstack(A + B + [y])]
    blades, rows, directions = [], [], []
    for w, R in enumerate(per_blade):
        # nearly dependent rows would need huge modal directions, whose round-off the
        # differences amplify by the condition number: the modal differencing then
        if R.shape[0] > R.shape[1] or np.linalg.cond(R) > MAX_INPUT_CONDITION:
            return None
        blades += [w] * R.shape[0]
        rows.append(R)
        directions.append(np.linalg.pinv(R).T)  # (r, m): R @ directions.T = I
    return np.array(blades), np.vstack(rows), np.vstack(directions)


@dataclasses.dataclass
class Linearisation:
    """Force derivatives of blade 0 at the time samples: ``dq``, ``dv`` ``(3, n_t, m, m)``
    d(force on blade 0)/d(q or q' of window blade w); ``force`` ``(n_t, m)``. The elastic
    law's, with each sample's slider held: ``dslider`` ``(3, n_t, s, m)`` d(slider that
    sample returns, the loop's ``s`` components)/d(q of window blade w)."""

    force: np.ndarray
    dq: np.ndarray
    dv: np.ndarray
    dslider: np.ndarray | None = None
