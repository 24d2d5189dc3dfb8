"""The serial reference of the transient: plain-numpy fixed-step loops over the reference force
model and a dense ``K_R`` (no PETSc, no compiled kernel), one per ``time.scheme``:

- ``"rk"``: an explicit Runge-Kutta step driven by a Butcher tableau like SciPy's ``RK23``
  (``A``, ``B``, ``C`` arrays, one generic step; Bogacki-Shampine = PETSc's ``3bs``);
- ``"exponential"``: ETDRK4 (Cox & Matthews 2002) with every blade's segment block
  ``L = [[0, I], [-A0, -beta_D A0]]`` propagated exactly (under the elastic law ``A0 + S``,
  the stuck springs' share, :mod:`wheelrom.transient.stuck_shift`), written a second time with
  numpy/scipy only, in the model's own basis: the exponential and the phi functions of the
  whole ``2 m x 2 m`` block from one ``scipy.linalg.expm`` of an augmented matrix (no
  eigen-decomposition of ``A0``, unlike the compiled step); everything else of ``K_R``
  (``A1``, a mistuned blade's ``delta_s K_seg``) and every force explicit, and the work
  accumulators ``W`` by the classical RK4 weights on the ETDRK4 stage states, as the compiled
  step (:func:`wheelrom.transient.exponential_kernel.etd4_step`) does.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from wheelrom.config import Config
from wheelrom.forces.parameters import force_parameters
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime.environment import petsc
from wheelrom.transient.preload import initial_state
from wheelrom.transient.problem import WheelProblem
from wheelrom.transient.stuck_shift import shift_matrix

SCHEMES = ("rk", "exponential")


@dataclass(frozen=True)
class Tableau:
    """An explicit Runge-Kutta scheme: ``A`` (s, s) strictly lower, weights ``B`` (s,),
    nodes ``C`` (s,); ``order`` of its solution."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    order: int


# Bogacki-Shampine: PETSc's "3bs" (Simulink ode3); FSAL, the 3rd-order solution is used
BOGACKI_SHAMPINE = Tableau(
    A=np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.75, 0.0]]),
    B=np.array([2.0 / 9.0, 1.0 / 3.0, 4.0 / 9.0]),
    C=np.array([0.0, 0.5, 0.75]),
    order=3,
)


def rk_step(fun, t: float, u: np.ndarray, h: float, tableau: Tableau) -> np.ndarray:
    """One explicit RK step of ``u' = fun(t, u)`` from ``t`` with step ``h``."""
    stages = np.empty((tableau.B.size, u.size))
    for i in range(tableau.B.size):
        du = tableau.A[i, :i] @ stages[:i] if i else 0.0
        stages[i] = fun(t + tableau.C[i] * h, u + h * du)
    return u + h * (tableau.B @ stages)


@dataclass(frozen=True)
class SegmentPropagators:
    """The exact part of one ETDRK4 step ``h`` for one blade's ``x = (q, q')`` (length
    ``2 m``), ``L = [[0, I], [-A0, -beta_D A0]]``, ``B = [0; I]`` (the explicit force acts
    on ``q''`` only): ``E = exp(h L)``, ``E_half = exp(h L / 2)`` ``(2 m, 2 m)``;
    ``phi1_half = phi_1(h L / 2) B`` and the ETDRK4 weights ``f1 = (phi_1 - 3 phi_2 +
    4 phi_3)(h L) B``, ``f2 = (phi_2 - 2 phi_3)(h L) B``, ``f3 = (-phi_2 + 4 phi_3)(h L) B``
    ``(2 m, m)``."""

    E: np.ndarray
    E_half: np.ndarray
    phi1_half: np.ndarray
    f1: np.ndarray
    f2: np.ndarray
    f3: np.ndarray


def _exp_and_phis(A0: np.ndarray, beta: float, tau: float, h: float):
    """``(exp(tau L), [phi_1, phi_2, phi_3](tau L) B)`` from one ``expm`` of the ``5 m``
    augmented matrix ``[[tau L', B, 0, 0], [0, 0, I, 0], [0, 0, 0, I], [0, 0, 0, 0]]``
    (the phi functions of ``tau L`` on ``B`` are its first block row). ``L'`` is ``L`` in
    the scaled variables ``(q / h, q')`` (``L = S L' S^-1``, ``S = diag(h I, I)``): entries
    ``tau h a`` of order one instead of ``tau a`` of order 1e6 for the stiff modes."""
    m = A0.shape[0]
    eye = np.eye(m)
    M = np.zeros((5 * m, 5 * m))
    M[:m, m : 2 * m] = (tau / h) * eye
    M[m : 2 * m, :m] = -tau * h * A0
    M[m : 2 * m, m : 2 * m] = -tau * beta * A0
    M[m : 2 * m, 2 * m : 3 * m] = eye  # B' = S^-1 B = B
    M[2 * m : 3 * m, 3 * m : 4 * m] = eye
    M[3 * m : 4 * m, 4 * m : 5 * m] = eye
    X = expm(M)
    scale = np.concatenate([np.full(m, h), np.ones(m)])  # S
    E = scale[:, None] * X[: 2 * m, : 2 * m] / scale[None, :]
    phis = [scale[:, None] * X[: 2 * m, (k + 2) * m : (k + 3) * m] for k in range(3)]
    return E, phis


def segment_propagators(A0: np.ndarray, beta: float, h: float) -> SegmentPropagators:
    """The :class:`SegmentPropagators` of step ``h`` [s] for the segment block ``A0``
    ``(m, m)`` [1/s^2] and the stiffness-proportional damping ``beta`` [s]."""
    A0 = np.asarray(A0, dtype=float)
    E, (p1, p2, p3) = _exp_and_phis(A0, beta, h, h)
    E_half, (p1_half, _, _) = _exp_and_phis(A0, beta, 0.5 * h, h)
    return SegmentPropagators(E=E, E_half=E_half, phi1_half=p1_half,
                              f1=p1 - 3.0 * p2 + 4.0 * p3, f2=p2 - 2.0 * p3,
                              f3=-p2 + 4.0 * p3)


def etdrk4_step(explicit, t: float, u: np.ndarray, h: float, prop: SegmentPropagators,
                blades: int) -> np.ndarray:
    """One ETDRK4 step (Cox & Matthews 2002) of ``u = (q, q', W)`` from ``t`` with step
    ``h``: ``q, q'`` blade-major ``(blades, m)``, every blade's ``(q_s, q'_s)`` propagated by
    ``prop``; ``explicit(t, u)`` returns the rest of the right-hand side (its ``q''`` rows:
    the forces and the part of ``K_R`` outside the segment blocks; its ``q'`` rows are not
    read; its ``W`` rows: the powers, integrated with the classical RK4 weights)."""
    m = prop.E.shape[0] // 2
    n = blades * m
    U = np.hstack([u[:n].reshape(blades, m), u[n : 2 * n].reshape(blades, m)])
    uw = u[2 * n :]
    half = 0.5 * h

    def force(g):
        return g[n : 2 * n].reshape(blades, m)

    def state(X, w):
        return np.concatenate([X[:, :m].ravel(), X[:, m:].ravel(), w])

    g_u = explicit(t, u)
    A = U @ prop.E_half.T + half * force(g_u) @ prop.phi1_half.T
    g_a = explicit(t + half, state(A, uw + half * g_u[2 * n :]))
    Bs = U @ prop.E_half.T + half * force(g_a) @ prop.phi1_half.T
    g_b = explicit(t + half, state(Bs, uw + half * g_a[2 * n :]))
    C = A @ prop.E_half.T + half * (2.0 * force(g_b) - force(g_u)) @ prop.phi1_half.T
    g_c = explicit(t + h, state(C, uw + h * g_b[2 * n :]))
    X = U @ prop.E.T + h * (force(g_u) @ prop.f1.T
                            + 2.0 * (force(g_a) + force(g_b)) @ prop.f2.T
                            + force(g_c) @ prop.f3.T)
    w = uw + (h / 6.0) * (g_u + 2.0 * (g_a + g_b) + g_c)[2 * n :]
    return state(X, w)


def explicit_part(problem: WheelProblem, propagated: np.ndarray | None = None):
    """``explicit(t, u)`` of :func:`etdrk4_step` for one case of ``problem`` (numpy only):
    ``q''`` rows ``f(q, q', t) - (K_R - I (x) A)(q + beta_D q')``, ``W`` rows the powers of
    :meth:`WheelProblem.rhs_numpy` (the damping power with the whole ``K_R``). ``A``: the
    propagated segment block ``propagated`` (default ``A0``; under the elastic law ``A0 +
    S``, :mod:`wheelrom.transient.stuck_shift`)."""
    model, n = problem.model, problem.n
    A = model.A0 if propagated is None else propagated
    K_off = problem.Kd - np.kron(np.eye(model.blades), A)
    forces, beta, Kd = problem.forces[0], problem.beta, problem.Kd

    def explicit(t: float, u: np.ndarray) -> np.ndarray:
        q, v = u[:n], u[n : 2 * n]
        force = forces.evaluate(t, q.reshape(model.blades, model.modes),
                                v.reshape(model.blades, model.modes),
                                problem.slider_view(u))
        out = np.zeros_like(u)  # the sliders' rate: zero within a step
        out[n : 2 * n] = force.ravel() - K_off @ (q + beta * v)
        out[2 * n : 2 * n + 3] = forces.power
        out[2 * n + 3] = -beta * float(v @ (Kd @ v))
        return out

    return explicit


def reference_solution(model: ReducedModel, cfg: Config, steps: int, step: float,
                       angles_deg: dict | None = None, sample_every: int = 1,
                       tableau: Tableau = BOGACKI_SHAMPINE,
                       u0: np.ndarray | None = None, scheme: str = "rk"):
    """``steps`` fixed steps of size ``step`` [s] from ``time.start``'s state (or from the
    modal state ``u0 = (q, q')`` of length ``2 N m``: the elastic law's sliders then start at
    rest there), with ``scheme`` ``"rk"`` (the explicit ``tableau``) or ``"exponential"``
    (ETDRK4, :func:`etdrk4_step`); under the elastic law every step ends with the sliders'
    return onto the Coulomb limit (:meth:`WheelProblem.slide`), as the compiled paths do.

    Returns ``(times, states, wall_s)`` with the blade-major state every ``sample_every``
    steps (and at ``t = 0``).
    """
    if scheme not in SCHEMES:
        raise ValueError(f"scheme must be one of {SCHEMES}, not {scheme!r}")
    t_wall = time.perf_counter()
    params = force_parameters(model, cfg, angles_deg)
    problem = WheelProblem(model, cfg, [params], petsc().COMM_SELF)
    if u0 is None:
        u, _ = initial_state(problem)
    else:
        u = problem.start_state(u0)
    if scheme == "exponential":
        # the block the compiled scheme propagates: A0 and the stuck springs' share
        propagated = model.A0 + shift_matrix(model, params)
        prop = segment_propagators(propagated, problem.beta, step)
        explicit = explicit_part(problem, propagated)

        def advance(t, x):
            return etdrk4_step(explicit, t, x, step, prop, model.blades)
    else:

        def advance(t, x):
            return rk_step(problem.rhs_numpy, t, x, step, tableau)

    times, states = [0.0], [u.copy()]
    for i in range(steps):
        u = advance(i * step, u)
        problem.slide(u)
        if (i + 1) % sample_every == 0:
            times.append((i + 1) * step)
            states.append(u.copy())
    problem.destroy()
    return np.array(times), np.array(states), time.perf_counter() - t_wall


def tip_difference(model: ReducedModel, reference: np.ndarray, final: np.ndarray) -> tuple:
    """``(relative, absolute [m], scale [m])``: the largest difference of every blade's tip
    displacement between the reference's last state and ``final`` (blade-major states),
    relative to the largest tip displacement over the reference's samples ``reference``
    ``(S, state)``. Over the run, not at the last instant: the nozzle's response passes
    near zero, and a difference of 4e-15 m read 3.9e-9 at such an instant against 9e-11
    of the run's largest displacement (the paper wheel after 220 steps)."""
    n = model.size

    def tip(state):
        return np.asarray(state)[..., :n].reshape(-1, model.blades, model.modes) @ model.tip.T

    absolute = float(np.abs(tip(reference[-1]) - tip(final)).max())
    scale = float(np.abs(tip(reference)).max())
    return absolute / max(scale, 1e-300), absolute, scale
