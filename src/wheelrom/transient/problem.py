"""The transient problem of the reduced wheel (paper eq. 15) and what a case run returns.

State ``u = (q, q', W, w)`` with ``q, q'`` of length ``N m``, four work accumulators
``W = (W_nozzle, W_vdp, W_friction, W_damping)`` [J] integrated with the same stages as the
motion, so the energy balance ``E(t) - E(0) = sum W`` is a check of the integration itself,
and under the elastic contact law the sliders ``w`` ``(K, N, 2)`` [m], which hold still
within a step and are returned onto the Coulomb limit at its end (docs/theory.md, "Contact
laws"):

    q''  = -K_R (q + beta_D q') + f(q, q', w, t)
    W'   = (P_nozzle, P_vdp, P_friction, -beta_D q'^T K_R q')

``W_friction`` is the work of the tangential contact forces on the blades; under the elastic
law it holds the stuck contacts' spring energy besides the slip dissipation (over a closed
cycle only the dissipation is left).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from wheelrom.config import Config, sample_every
from wheelrom.forces.parameters import ForceParameters
from wheelrom.forces.reference import ReferenceForces
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime.environment import petsc
from wheelrom.transient.layout import H_RHS_CALLS, Context

N_WORK = 4
WORK_NAMES = ("nozzle", "van_der_pol", "friction", "damping")


@dataclass(frozen=True)
class WindowStats:
    """Statistics of one case over one window's output samples (NaN when it has none).

    ``max_tip_amplitude`` [m]: largest tip displacement magnitude over blades and samples;
    ``nd_spectrum``: ``(N // 2 + 1,)`` largest amplitude over the samples of each nodal
    diameter component of the tip ``y`` displacement [m] (:func:`nd_amplitudes`);
    ``min_normal_force``: kind -> smallest normal force [N]; ``open_fraction``,
    ``slip_fraction``: kind -> fraction of (blade, sample) pairs with the contact open, or
    slipping (elastic law: beyond the Coulomb limit; paper law: above ``v_k``); the rest
    sticks (paper law: the micro-slip branch).
    """

    max_tip_amplitude: float
    nd_spectrum: np.ndarray
    min_normal_force: dict
    open_fraction: dict
    slip_fraction: dict


def nd_amplitudes(tip_y: np.ndarray) -> np.ndarray:
    """Amplitude [m] of every nodal-diameter component of blade displacements ``tip_y``
    ``(..., N)``: ``(..., N // 2 + 1)``.

    A travelling wave ``a cos(k theta_s - w t)`` of ND ``0 < k < N/2`` appears with DFT
    magnitude ``a N / 2`` at ``k`` (and at ``N - k``), a pattern of ND 0 or ``N/2`` with
    ``a N``: scaled by ``2/N`` and ``1/N`` respectively, every ND reports the amplitude ``a``.
    """
    N = tip_y.shape[-1]
    scale = np.full(N // 2 + 1, 2.0 / N)
    scale[0] = 1.0 / N
    if N % 2 == 0:
        scale[-1] = 1.0 / N
    return np.abs(np.fft.rfft(tip_y, axis=-1)) * scale


@dataclass
class CaseResult:
    """Monitor output of one case (arrays per window ``w`` unless noted).

    Attributes:
        status: ``"done"`` or ``"failed: <reason>"``.
        window_end: ``(W,)`` end time of each window [s].
        max_tip_amplitude, nd_spectrum, min_normal_force, open_fraction, slip_fraction: the
            :class:`WindowStats` of every window, stacked: ``(W,)``, ``(W, N//2+1)``,
            kind -> ``(W,)``.
        energy: ``(W,)`` kinetic + potential energy at window end [J]; ``energy0`` at t = 0.
        work: ``(W, 4)`` cumulative work of nozzle, Van der Pol, friction, damping [J].
        sample_time: ``(S,)`` [s]; tip_history: ``(S, N, 3)`` tip displacement [m]: the
            stored tip history, every k-th statistics sample (``output.history_rate_hz``;
            none when it is 0).
        state_time: ``(S2,)`` [s]; state_history: ``(S2, 2, N, m)`` modal displacements
            ``q`` [sqrt(kg) m] and velocities ``q'`` [sqrt(kg) m/s] of every blade at
            ``output.state_rate_hz`` (empty when it is 0).
        steps, rhs_evaluations, wall_s, options: TS steps taken, right-hand sides of the
            TS (of the whole batch), wall time [s] of the integration (of a batch: its wall
            time over its number of cases; compiling or loading kernels not included), TS
            options used (prefix stripped).
        compile_s: seconds this process spent loading the compiled kernels from the cache or
            compiling them before the integration (0 when it had them already; of a batch:
            over its number of cases, as ``wall_s``).
        preload_residual: ``|K_R q - f|`` of the static preload start, when used.
        final_state: ``(2 N m + 4,)`` blade-major state at the end.
        batch: number of cases integrated together in the TS of this case.
        linear: the case's linear stability (``growth_rate`` [1/s], ``nodal_diameter``,
            ``frequency_hz`` of the fastest mode) when computed (sweeps do).
        classification: both analyses in words (``wheelrom.analysis.stability.classify``).
    """

    status: str = "done"
    window_end: np.ndarray = field(default_factory=lambda: np.zeros(0))
    max_tip_amplitude: np.ndarray = field(default_factory=lambda: np.zeros(0))
    min_normal_force: dict = field(default_factory=dict)
    open_fraction: dict = field(default_factory=dict)
    slip_fraction: dict = field(default_factory=dict)
    nd_spectrum: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    energy: np.ndarray = field(default_factory=lambda: np.zeros(0))
    energy0: float = 0.0
    work: np.ndarray = field(default_factory=lambda: np.zeros((0, N_WORK)))
    sample_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    tip_history: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    state_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    state_history: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 0, 0)))
    steps: int = 0
    rhs_evaluations: int = 0
    wall_s: float = 0.0
    compile_s: float = 0.0
    options: dict = field(default_factory=dict)
    preload_residual: float | None = None
    final_state: np.ndarray | None = None
    batch: int = 1
    linear: dict | None = None
    classification: str = ""

    def growth_rates(self, tail: float = 0.5) -> tuple[float, np.ndarray]:
        """``(tip, per ND)`` growth rates [1/s]: slopes of ``log`` of the window amplitudes
        (``max_tip_amplitude``, ``nd_spectrum`` ``(N//2+1,)``) over the last ``tail`` of the
        windows (at least 2); NaN with fewer than 2 windows."""
        W = self.window_end.size
        if W < 2:
            return float("nan"), np.full(self.nd_spectrum.shape[1:], np.nan)
        last = max(2, int(np.ceil(tail * W)))
        t = self.window_end[-last:]
        logs = np.log(np.maximum(np.column_stack([self.max_tip_amplitude[-last:],
                                                  self.nd_spectrum[-last:]]), 1e-300))
        slopes = np.polyfit(t - t.mean(), logs, 1)[0]
        return float(slopes[0]), slopes[1:]

    def energy_balance_error(self) -> float:
        """``|E - E0 - sum W| / sum |W|`` at the last window (0 when nothing happened)."""
        if self.energy.size == 0:
            return 0.0
        total = self.work[-1].sum()
        scale = np.abs(self.work[-1]).sum()
        return float(abs(self.energy[-1] - self.energy0 - total) / scale) if scale else 0.0

    def summary(self) -> dict:
        """The last window's figures as plain Python values (for printing and JSON)."""
        last = -1 if self.window_end.size else None
        return {
            "status": self.status,
            "steps": self.steps,
            "wall_s": self.wall_s,
            "compile_s": self.compile_s,
            "simulated_s": float(self.window_end[-1]) if last is not None else 0.0,
            "max_tip_amplitude": float(self.max_tip_amplitude[-1]) if last is not None else None,
            "min_normal_force": {
                k: float(v[-1]) for k, v in self.min_normal_force.items() if v.size
            },
            "open_fraction": {k: float(v[-1]) for k, v in self.open_fraction.items() if v.size},
            "slip_fraction": {k: float(v[-1]) for k, v in self.slip_fraction.items() if v.size},
            "energy_balance_error": self.energy_balance_error(),
            "preload_residual": self.preload_residual,
            "options": self.options,
            "growth_rate": self.growth_rates()[0],
            "linear": self.linear,
            "classification": self.classification,
        }


class WheelProblem:
    """The ODE of one case or of a batch of cases: sizes, the compiled context and the TS
    callbacks (``comm``: ``COMM_SELF``, a case is serial).

    ``cases``: one :class:`ForceParameters` per case of the batch (cases differing only in
    contact angles, integrated together in one TS: see :mod:`wheelrom.transient.layout`).
    Two right-hand sides: the compiled one (:mod:`wheelrom.transient.kernel`, registered as C
    callbacks, the default) and :meth:`rhs`, a petsc4py Python callback using the PETSc BAIJ
    ``K_R`` and the reference force model (one case: slower, a second implementation).
    ``n``, :meth:`size`, :meth:`rhs_numpy`, :meth:`energy` refer to one case.
    """

    def __init__(self, model: ReducedModel, cfg: Config, cases: list[ForceParameters], comm,
                 capacity: int = 4, state_capacity: int = 0):
        self.comm = comm
        self.cases = list(cases)
        self.model, self.cfg = model, cfg
        self.B = len(self.cases)
        self.N, self.m = model.blades, model.modes
        self.n = self.N * self.m
        self.kinds = self.cases[0].contacts.kinds
        self.beta = cfg.wheel.damping_beta
        self.Kd = model.dense_stiffness()  # for energies and the reference (small)
        self.context = Context(
            self.cases,
            model,
            self.beta,
            sample_dt=1.0 / cfg.output.sample_rate_hz,
            limit=cfg.time.divergence_amplitude,
            capacity=capacity,
            state_every=sample_every(cfg.output.state_rate_hz, cfg.output.sample_rate_hz),
            state_capacity=state_capacity,
        )
        self.forces = [ReferenceForces(p) for p in self.cases]
        self._petsc: list = []  # BAIJ K_R and work Vecs of the Python path, made on demand

    def size(self) -> int:
        """Length of one case's state ``(q, q', W, w)`` (:func:`~.layout.state_size`)."""
        return 2 * self.n + N_WORK + self.sliders

    @property
    def sliders(self) -> int:
        """Slider coordinates of one case (``2 K N`` under the elastic law, else 0)."""
        return self.cases[0].sliders

    def slider_view(self, u: np.ndarray) -> np.ndarray | None:
        """``(K, N, 2)`` view of the sliders of one case's blade-major state (None: the
        paper law has none)."""
        if not self.sliders:
            return None
        return u[2 * self.n + N_WORK :].reshape(len(self.kinds), self.N, 2)

    def rest_sliders(self, u: np.ndarray, case: int = 0) -> None:
        """One case's sliders in ``u`` (blade-major, in place) at rest at its displacement:
        no tangential force there (nothing under the paper law)."""
        slider = self.slider_view(u)
        if slider is not None:
            slider[...] = self.forces[case].sliders_at_rest(u[: self.n].reshape(self.N, self.m))

    def start_state(self, given: np.ndarray, case: int = 0) -> np.ndarray:
        """One case's whole state from ``given``: ``(q, q')`` (the elastic law's sliders at
        rest there) or a whole state (its sliders kept; the work integrals start at zero),
        the sliders then returned onto the Coulomb limit (a start beyond the stick range
        slips)."""
        given = np.asarray(given, dtype=float)
        u = np.zeros(self.size())
        n2 = 2 * self.n
        u[:n2] = given[:n2]
        if self.sliders:
            if given.size == u.size:
                u[n2 + N_WORK :] = given[n2 + N_WORK :]
            else:
                self.rest_sliders(u, case)
            self.slide(u, case)
        return u

    def slide(self, u: np.ndarray, case: int = 0) -> bool:
        """The end of a step (Python paths): one case's sliders in ``u`` (blade-major, in
        place) returned onto the Coulomb limit at its state; True when one moved."""
        slider = self.slider_view(u)
        if slider is None:
            return False
        n, forces = self.n, self.forces[case]
        forces.evaluate(0.0, u[:n].reshape(self.N, self.m),
                        u[n : 2 * n].reshape(self.N, self.m), slider)
        moved = not np.array_equal(forces.slider_next, slider)
        slider[...] = forces.slider_next
        return moved

    def rhs(self, ts, t, u, f):
        """Python TS callback (one case): ``f = (q', q'', W')`` with BAIJ products."""
        PETSc = petsc()
        if not self._petsc:
            K = self.model.petsc_stiffness(self.comm)
            self._petsc = [K] + [PETSc.Vec().createSeq(self.n, comm=self.comm) for _ in "xqv"]
        K, x, Kq, Kv = self._petsc
        self.context.array[H_RHS_CALLS] += 1
        n, forces = self.n, self.forces[0]
        ua = u.getArray(readonly=True)
        fa = f.getArray()
        q = ua[:n]
        v = ua[n : 2 * n]
        x.setArray(q)
        K.mult(x, Kq)
        x.setArray(v)
        K.mult(x, Kv)
        force = forces.evaluate(t, q.reshape(self.N, self.m), v.reshape(self.N, self.m),
                                self.slider_view(ua))
        Kqa = Kq.getArray(readonly=True)
        Kva = Kv.getArray(readonly=True)
        fa[:n] = v
        fa[n : 2 * n] = force.ravel() - Kqa - self.beta * Kva
        fa[2 * n : 2 * n + 3] = forces.power
        fa[2 * n + 3] = -self.beta * float(v @ Kva)
        fa[2 * n + N_WORK :] = 0.0  # the sliders move only when a step ends (slide)

    def rhs_numpy(self, t: float, u: np.ndarray, case: int = 0) -> np.ndarray:
        """The same right-hand side with numpy only (serial reference), one case."""
        n = self.n
        q, v = u[:n], u[n : 2 * n]
        forces = self.forces[case]
        force = forces.evaluate(t, q.reshape(self.N, self.m), v.reshape(self.N, self.m),
                                self.slider_view(u))
        Kv = self.Kd @ v
        out = np.zeros_like(u)  # the sliders' rate is zero (they move when a step ends)
        out[:n] = v
        out[n : 2 * n] = force.ravel() - self.Kd @ q - self.beta * Kv
        out[2 * n : 2 * n + 3] = forces.power
        out[2 * n + 3] = -self.beta * float(v @ Kv)
        return out

    def energy(self, u: np.ndarray, case: int = 0) -> float:
        """Kinetic + modal strain + contact spring energy [J] of one case's blade-major state
        (evaluates the contacts)."""
        n = self.n
        q, v = u[:n], u[n : 2 * n]
        forces = self.forces[case]
        forces.evaluate(0.0, q.reshape(self.N, self.m), v.reshape(self.N, self.m),
                        self.slider_view(u))
        return 0.5 * float(v @ v) + 0.5 * float(q @ (self.Kd @ q)) + forces.contact_energy()

    def destroy(self) -> None:
        """Free the PETSc objects of the Python right-hand side."""
        for obj in self._petsc:
            obj.destroy()
        self._petsc = []
