"""The serial reference of the transient: a plain-numpy explicit Runge-Kutta loop with a fixed
step over the reference force model and a dense ``K_R`` (no PETSc, no compiled kernel), driven
by a Butcher tableau like SciPy's ``RK23`` (``A``, ``B``, ``C`` arrays, one generic step)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from wheelrom.config import Config
from wheelrom.forces.parameters import force_parameters
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime.environment import petsc
from wheelrom.transient.preload import initial_state
from wheelrom.transient.problem import WheelProblem


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


def reference_solution(model: ReducedModel, cfg: Config, steps: int, step: float,
                       angles_deg: dict | None = None, sample_every: int = 1,
                       tableau: Tableau = BOGACKI_SHAMPINE,
                       u0: np.ndarray | None = None):  # fmt: skip
    """``steps`` fixed steps of size ``step`` [s] from ``time.start``'s state (or from the
    modal state ``u0 = (q, q')`` of length ``2 N m``).

    Returns ``(times, states, wall_s)`` with the blade-major state every ``sample_every``
    steps (and at ``t = 0``).
    """
    t_wall = time.perf_counter()
    params = force_parameters(model, cfg, angles_deg)
    problem = WheelProblem(model, cfg, [params], petsc().COMM_SELF)
    if u0 is None:
        u, _ = initial_state(problem)
    else:
        u = np.zeros(problem.size())
        u[: u0.size] = u0
    times, states = [0.0], [u.copy()]
    for i in range(steps):
        u = rk_step(problem.rhs_numpy, i * step, u, step, tableau)
        if (i + 1) % sample_every == 0:
            times.append((i + 1) * step)
            states.append(u.copy())
    problem.destroy()
    return np.array(times), np.array(states), time.perf_counter() - t_wall
