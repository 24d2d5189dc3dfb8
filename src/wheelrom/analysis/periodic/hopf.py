"""Where each travelling wave of a tuned wheel loses stability as the self-excitation grows:
its ND block of the Jacobian at the preloaded equilibrium, affine in the factor ``lam`` on the
self-excitation (the flutter margin's ``J_0 + lam J_1``, per wave ``k = 0..N-1``), its fastest
forward mode and its Hopf point (docs/theory.md, "Limit cycles")."""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from wheelrom.analysis.jacobian import aero_stiffness, van_der_pol_damping
from wheelrom.analysis.stability import blade_blocks, is_circulant, nd_block
from wheelrom.forces.parameters import ForceParameters
from wheelrom.rom.model import ReducedModel

GROWTH_TOLERANCE = 1e-6  # [1/s] as the linear verdict


def wave_blocks(model: ReducedModel, params: ForceParameters, q: np.ndarray, J):
    """``(B0, B1)`` ``(N, 2m, 2m)`` complex: the ND blocks of every wave ``k = 0..N-1`` of the
    Jacobian without and per unit factor of the self-excitation."""
    N, m = q.shape
    zero = sp.csr_matrix((N * m, N * m))
    J1 = sp.bmat([[zero, zero], [aero_stiffness(params, N, m), van_der_pol_damping(params, q)]],
                 format="csr")
    J0 = (sp.csr_matrix(J) - J1).tocsr()
    if not (is_circulant(J0, N, m) and is_circulant(J1, N, m)):
        raise ValueError("limit cycles need a cyclic (tuned) wheel")
    r0, r1 = blade_blocks(J0, N, m), blade_blocks(J1, N, m)
    return (np.stack([nd_block(r0, k) for k in range(N)]),
            np.stack([nd_block(r1, k) for k in range(N)]))


def wave_mode(B0, B1, lam):
    """``(growth [1/s], eigenvalue, vector)`` of the fastest forward mode (``Im > 0``) of one
    wave's block ``B0 + lam B1`` (:func:`wave_blocks`) at factor ``lam``."""
    values, vectors = np.linalg.eig(B0 + lam * B1)
    forward = np.flatnonzero(values.imag > 0)
    i = forward[int(np.argmax(values.real[forward]))]
    return float(values.real[i]), values[i], vectors[:, i]


def hopf_point(B0, B1, lam_max: float, rtol: float = 1e-10) -> float:
    """The smallest factor ``lam`` in ``[0, lam_max]`` at which the wave's fastest forward mode
    crosses (bisection after a doubling scan); ``nan`` when it stays stable; 0 when it is
    unstable without self-excitation."""
    if wave_mode(B0, B1, 0.0)[0] > GROWTH_TOLERANCE:
        return 0.0
    grid = np.concatenate([[0.0], lam_max * 2.0 ** np.arange(-20, 1)])
    unstable = [wave_mode(B0, B1, lam)[0] > 0 for lam in grid[1:]]
    if not any(unstable):
        return math.nan
    first = unstable.index(True)
    low, high = grid[first], grid[first + 1]
    while high - low > rtol * high:
        middle = 0.5 * (low + high)
        low, high = (low, middle) if wave_mode(B0, B1, middle)[0] > 0 else (middle, high)
    return 0.5 * (low + high)


def unstable_seed(model: ReducedModel, B0, B1, amplitude: float, seed: int):
    """``(waves, q (N, m), q' (N, m), eigenvalue)``: the growing modes of every unstable wave
    (growth >
    ``GROWTH_TOLERANCE`` at factor 1; the fastest wave alone when none grows) as one real
    start, a solution of the linearised equations about the equilibrium, and the fastest
    wave's eigenvalue [1/s] (its frequency is the start's).

    Each wave ``k`` contributes its fastest forward mode ``v_k`` (:func:`wave_mode`, the
    ``(q, q')`` amplitudes of blade 0; blade ``s`` has ``v_k e^{i 2 pi k s / N}``), scaled to a
    unit tip displacement of blade 0 and turned by a random phase ``theta_k`` (numpy
    ``default_rng(seed)``, as ``time.perturbation``'s); the sum is scaled so that its largest
    complex tip amplitude (for one wave: the tip's peak over the period) is ``amplitude`` [m]
    (for a mode that hardly moves the tip, :func:`tip_measure`), and its real part is the
    start. Sized on the complex amplitude, not on the real part's displacement: at a phase
    where the displacement passes through zero that would blow the velocity up (measured:
    a "1 nm" seed of the paper wheel's ND 33 at 70 deg moved the tip by 0.5 um). Why the
    mode itself and not the lowest mode of the ND (``time.perturbation``'s pattern): the
    stuck wheel of the elastic law flutters in a 423 Hz family that the lowest mode of ND 33
    (133 Hz) hardly seeds."""
    N, m = model.blades, model.modes
    modes = [wave_mode(B0[k], B1[k], 1.0) for k in range(N)]
    growth = np.array([g for g, _, _ in modes])
    waves = [int(k) for k in np.flatnonzero(growth > GROWTH_TOLERANCE)]
    waves = waves or [int(np.argmax(growth))]
    theta = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, N)
    blades = np.arange(N)
    state = np.zeros((N, 2 * m), dtype=complex)
    reach = np.linalg.norm(model.tip, 2)  # [m per sqrt(kg) m]: the most a unit q moves the tip
    for k in waves:
        vector = modes[k][2]
        tip = model.tip @ vector[:m]  # (3,) complex tip displacement of blade 0
        wave = np.exp(1j * (theta[k] + 2 * np.pi * k * blades / N))  # (N,)
        state += wave[:, None] * (vector / tip_measure(tip, vector[:m], reach))[None, :]
    q = state[:, :m]
    scale = amplitude / tip_measure(np.linalg.norm(q @ model.tip.T, axis=1).max(), np.abs(q),
                                    reach)
    state = (state * scale).real
    return waves, state[:, :m], state[:, m:], modes[int(np.argmax(growth))][1]


def tip_measure(tip, q: np.ndarray, reach: float) -> float:
    """The tip displacement ``tip`` [m] of modal displacements ``q`` as their size, or, for a
    motion that hardly moves the tip (a growing torsion of the shroud, say: below 1e-6 of what
    ``q`` could move it), ``reach`` times the largest modal displacement: the seed is then
    sized as if that moved the tip, never divided by round-off."""
    size, most = float(np.linalg.norm(tip)), reach * float(np.abs(q).max())
    return size if size > 1e-6 * most else most
