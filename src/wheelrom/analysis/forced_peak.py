"""The peak of the forced response over a frequency band, independent of any frequency grid
(issue #22; docs/theory.md "Peak refinement").

The default damping gives damping ratios of 2e-5..5e-4: half-power bandwidths of a few mHz at
100 Hz, far below any affordable grid. The peak of the largest blade amplitude
``a(w) = max_s |tip . Q_s(w)|`` is therefore searched where it can be:

1. candidates: the undamped eigenfrequencies ``w_r`` of the linearised ``K`` inside the band
   (dense symmetric ``eigh`` of ``K``; a ``K`` that is not symmetric to 1e-10 goes through the
   general eigenvalues, ``w_r = sqrt(Re lambda_r)``), each with its modal damping ratio
   ``zeta_r = phi_r^T C phi_r / (2 w_r)``, less the modes the nozzle hardly excites (their
   own resonant amplitude ``max_s |tip . phi_rs| |phi_r^H F| / (2 zeta_r w_r^2)`` below
   ``PRUNE`` of the largest: a tuned wheel keeps the excited ND's pair), and the local
   maxima of a coarse grid of ``forced.points`` frequencies over the band (endpoints
   included: a safety net for peaks away from every eigenfrequency; a grid maximum whose
   neighbours enclose an eigenfrequency candidate is left to it);
2. ``a`` at every candidate (one solve each);
3. the candidates within ``REFINE_RATIO`` of the best are refined by bounded Brent
   maximisation (scipy) on the bracket ``w_r +- KAPPA zeta_r w_r`` (``KAPPA`` half-power
   half-widths), or between a grid maximum's neighbours, to ``X_TOL`` of the bracket
   (amplitude error ~ ``X_TOL^2``); an optimum on the bracket's edge is searched again about
   it.

The automatic band is centred on the tuned wheel's resonance ``w_0`` of the excited ND's mode
family ``forced.family``, with half-width ``max(1 %, 2 max |delta_s|) w_0``: a blade of
stiffness ``(1 + delta) Lambda`` moves its frequencies by about ``delta / 2``, so the band holds
the family's mistuned modes with a margin of 4 (``max`` over every realisation that shares
the tuned reference, so that all of them and the reference search the same band).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
from scipy.optimize import minimize_scalar

from wheelrom.analysis.forced import (
    PREFIX,
    HarmonicSolver,
    SpeedFollowing,
    nozzle_amplitude,
    operators,
    speed_following,
    tip_amplitudes,
    tuned_copy,
)
from wheelrom.analysis.stability import nd_block
from wheelrom.config import Config
from wheelrom.rom.model import ReducedModel, nodal_diameter, nodal_diameters_of
from wheelrom.runtime.errors import InputError

KAPPA = 4.0  # bracket half-width of an eigenfrequency candidate [half-power half-widths]
REFINE_RATIO = 0.5  # candidates at least this share of the best amplitude are refined
PRUNE = 0.02  # modes whose own resonance is below this share of the largest are no candidates
X_TOL = 1e-4  # Brent's tolerance as a share of the bracket half-width
RECENTRE = 4  # searches about an optimum found on its bracket's edge
ZOOM = 0.02  # a bracket wider than the modal one is searched again this much narrower
ZOOMS = 4  # at most this many times
MIN_HALF_BAND = 0.01  # the automatic band's least half-width, share of the resonance
BAND_PER_DELTA = 2.0  # the automatic band's half-width per max |delta_s|
ZETA_FLOOR = 1e-9  # least |zeta_r| (Van der Pol's negative damping: still a sharp peak)
SYMMETRY_TOL = 1e-10  # ||K - K^T|| / ||K|| below which K's symmetric part is K


@dataclass
class PeakResponse:
    """The peak of the largest blade tip amplitude over a band.

    ``amplitude`` [m] at ``frequency`` [rad/s]; ``blade_amplitude`` ``(N,)`` every blade's tip
    amplitude there [m]; ``band`` ``(lo, hi)`` [rad/s]; ``solves``: linear solves (KSP) in
    all; ``candidates``: candidate peaks evaluated (``modes`` of them eigenfrequencies);
    ``refined``: candidates refined; ``wall_s``, ``setup_s`` (eigenvalues) [s];
    ``grid`` ``(F,)`` the coarse grid [rad/s] and ``grid_blade_amplitude`` ``(F, N)`` [m];
    ``solver``: the KSP's settings (:func:`wheelrom.analysis.forced.ksp_settings`).
    """

    amplitude: float
    frequency: float
    blade_amplitude: np.ndarray
    band: tuple[float, float]
    solves: int
    candidates: int
    modes: int
    refined: int
    wall_s: float = 0.0
    setup_s: float = 0.0
    grid: np.ndarray | None = None
    grid_blade_amplitude: np.ndarray | None = None
    solver: dict = field(default_factory=dict)

    @property
    def frequency_hz(self) -> float:
        return self.frequency / (2 * math.pi)

    @property
    def band_hz(self) -> tuple[float, float]:
        return self.band[0] / (2 * math.pi), self.band[1] / (2 * math.pi)


def half_band(deltas) -> float:
    """The automatic band's half-width as a share of the resonance for the mistuning
    patterns ``deltas`` (each ``(N,)`` or None: tuned)."""
    largest = max((float(np.abs(d).max()) for d in deltas if d is not None), default=0.0)
    return max(MIN_HALF_BAND, BAND_PER_DELTA * largest)


def resonance(K, model: ReducedModel, stator_vanes: int, family: int = 0,
              speed: SpeedFollowing | None = None) -> float:
    """Frequency [rad/s] of mode ``family`` (0: lowest) at the excited ND of a tuned wheel of
    stiffness ``K`` (CSR ``(N m, N m)``, blade-major): the eigenvalues of the ND block
    ``sum_d K_{0,d} e^{i 2 pi k d / N}``, ``k = n_s mod N`` (a ``K`` that is not
    block-circulant: its dense eigenpairs of that ND). Over the speed (``speed``): the
    Campbell crossing of the engine order with that mode (:func:`crossings`)."""
    N, m = model.blades, model.modes
    if family >= m:
        raise InputError(f"forced.family = {family}: the model has {m} mode families (0.."
                         f"{m - 1}: wheel.modes_per_segment and its basis's vectors)")
    k = stator_vanes % N
    K = sp.csr_matrix(K)
    shift = np.roll(np.arange(N * m), m)
    if abs(K - K[shift][:, shift]).max() <= 1e-10 * abs(K).max():
        block = nd_block(K[:m].toarray().reshape(m, N, m).transpose(1, 0, 2), k)  # K_{0,d}
        block = 0.5 * (block + block.conj().T)
        if speed is not None:
            lam = crossings(*speed.crossing_problem(block, speed.S[:m, :m].toarray()))[0]
            return math.sqrt(max(lam[min(family, lam.size - 1)], 0.0))
        lam = np.linalg.eigvalsh(block)
        return math.sqrt(max(lam[family], 0.0))
    if speed is not None:  # every ND's crossings, then the excited ND's as below
        lam, vec = crossings(*speed.crossing_problem(K))
    else:
        lam, vec = np.linalg.eigh(0.5 * (K + K.T).toarray())
    nd = nodal_diameters_of(vec.T.reshape(-1, N, m))
    mine = lam[nd == nodal_diameter(k, N)]
    single = nodal_diameter(k, N) in (0, N / 2)  # standing: one mode per family, else pairs
    return math.sqrt(max(mine[family if single else 2 * family], 0.0))


def crossings(A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(w^2, x)``: the Campbell crossings ``A x = w^2 B x`` of
    :meth:`~wheelrom.analysis.forced.SpeedFollowing.crossing_problem`, real and positive,
    ascending [(rad/s)^2], with their vectors (the general eigensolver: ``B`` is definite
    only while no mode stiffens with the speed faster than the engine order's line rises)."""
    lam, vec = sl.eig(A, B)
    keep = np.isfinite(lam) & (np.abs(lam.imag) <= 1e-9 * np.abs(lam)) & (lam.real > 0)
    order = np.argsort(lam[keep].real)
    return lam[keep].real[order], vec[:, keep][:, order]


def band_of(cfg: Config, centre: float, deltas) -> tuple[float, float]:
    """``(lo, hi)`` [rad/s]: ``forced.band_hz`` when given, else the automatic band about
    ``centre`` [rad/s] for the patterns ``deltas`` (module docstring)."""
    if cfg.forced.band_hz:
        lo, hi = cfg.forced.band_hz
        return 2 * math.pi * lo, 2 * math.pi * hi
    h = half_band(deltas)
    return centre * (1 - h), centre * (1 + h)


def modal_candidates(K, C, band: tuple[float, float], model: ReducedModel | None = None,
                     F: np.ndarray | None = None,
                     speed: SpeedFollowing | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(w_r, zeta_r)`` of the undamped modes of ``K`` inside ``band`` [rad/s]: frequencies
    [rad/s] and modal damping ratios ``phi_r^T C phi_r / (2 w_r)`` (unit ``phi_r``). With
    ``model`` and the force ``F``, only the modes whose own resonant tip amplitude
    ``max_s |tip . phi_rs| |phi_r^H F| / (2 |zeta_r| w_r^2)`` is at least ``PRUNE`` of the
    largest (the others cannot make the peak: ``F`` hardly excites them)."""
    lo, hi = band
    if not hi > lo:
        return np.zeros(0), np.zeros(0)
    Kd = K.toarray()
    asymmetry = np.linalg.norm(Kd - Kd.T) / max(np.linalg.norm(Kd), 1e-300)
    if speed is not None:  # the Campbell crossings in the band, each at its own speed
        A, B = speed.crossing_problem(K)
        try:  # symmetric and definite: the band's alone (4x faster on the paper wheel)
            if asymmetry > SYMMETRY_TOL:
                raise np.linalg.LinAlgError("not symmetric")
            lam, phi = sl.eigh(0.5 * (A + A.T), B, subset_by_value=(lo**2, hi**2))
        except np.linalg.LinAlgError:
            lam, phi = sl.eig(A, B)
            keep = np.isfinite(lam) & (lam.real > lo**2) & (lam.real <= hi**2)
            lam, phi = lam[keep].real, phi[:, keep]
    elif asymmetry <= SYMMETRY_TOL:
        lam, phi = sl.eigh(0.5 * (Kd + Kd.T), subset_by_value=(lo**2, hi**2))
    else:  # friction can make the linearised stiffness non-symmetric
        lam, phi = sl.eig(Kd)
        keep = (lam.real > lo**2) & (lam.real <= hi**2)
        lam, phi = lam[keep].real, phi[:, keep]
    w = np.sqrt(lam)
    phi = phi / np.maximum(np.linalg.norm(phi, axis=0), 1e-300)
    zeta = np.real(np.einsum("ir,ir->r", phi.conj(), C @ phi)) / (2 * np.maximum(w, 1e-300))
    if speed is not None:  # the damping's share of each crossing's own speed, per B-mass
        moved = np.real(np.einsum("ir,ir->r", phi.conj(), speed.S @ phi))
        mass = 1.0 - moved / speed.engine_order**2
        shifts = np.array([speed.shift(x) for x in w])
        zeta = (zeta + speed.beta * shifts * moved / (2 * np.maximum(w, 1e-300))) / mass
    if model is None or F is None or w.size == 0:
        return w, zeta
    shapes = phi.T.reshape(-1, model.blades, model.modes)  # (R, N, m)
    tip = np.sqrt((np.abs(shapes @ model.tip.T) ** 2).sum(axis=2)).max(axis=1)  # (R,)
    force = np.abs(phi.conj().T @ np.asarray(F).ravel())
    # |zeta| >= 1e-9: Van der Pol's negative damping still gives a finite, sharp peak
    alone = tip * force / (2 * np.maximum(np.abs(zeta), ZETA_FLOOR) * w**2)
    keep = alone >= PRUNE * alone.max()
    return w[keep], zeta[keep]


class _Amplitude:
    """``a(w)``: the largest blade amplitude [m] at ``w`` [rad/s], every solve remembered."""

    def __init__(self, model, solver: HarmonicSolver, F: np.ndarray):
        self.model, self.solver, self.F = model, solver, F
        self.seen: dict[float, np.ndarray] = {}

    def blades(self, w: float) -> np.ndarray:
        w = float(w)
        if w not in self.seen:
            self.seen[w] = tip_amplitudes(self.model, self.solver.solve(self.F, w))
        return self.seen[w]

    def __call__(self, w: float) -> float:
        return float(self.blades(w).max())

    def best(self) -> float:
        return max(self.seen, key=lambda w: self.seen[w].max())


def _refine(a: _Amplitude, lo: float, hi: float, band: tuple[float, float],
            finest: float) -> None:
    """Bounded Brent minimisation of ``1 / a^2`` on ``[lo, hi]`` in the scaled variable
    ``x = (w - centre) / half`` (tolerance ``X_TOL`` of the bracket), searched again about an
    optimum on the bracket's edge (up to ``RECENTRE`` times, within ``band``) and, while the
    bracket is wider than ``finest`` [rad/s] (a grid maximum's bracket), in a bracket
    ``ZOOM`` times as wide about the optimum."""
    for _ in range(RECENTRE + ZOOMS + 1):
        lo, hi = max(lo, band[0]), min(hi, band[1])
        centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        if half <= 0:
            return
        # 1 / a^2 is nearly a parabola about a resonance (|k - w^2 + i w c|^2): Brent's
        # parabolic steps converge in a few solves where -a (a Lorentzian) needs many
        found = minimize_scalar(lambda x, c=centre, h=half: a(c + x * h) ** -2.0,
                                bounds=(-1.0, 1.0), method="bounded",
                                options={"xatol": X_TOL})
        x = float(found.x)
        w = centre + x * half
        a(w)
        if abs(x) >= 1 - 10 * X_TOL:  # on the edge: the peak lies beyond it
            if w <= band[0] * (1 + 1e-12) or w >= band[1] * (1 - 1e-12):
                return
            lo, hi = w - half, w + half
            continue
        if half <= finest * (1 + 1e-9):
            return
        half = max(finest, ZOOM * half)
        lo, hi = w - half, w + half


def peak_of(model: ReducedModel, F: np.ndarray, K, C, band: tuple[float, float],
            points: int, use_modes: bool = True, comm=None, prefix: str = PREFIX,
            speed: SpeedFollowing | None = None) -> PeakResponse:
    """The peak of the response to ``F`` ``(N, m)`` of the wheel ``(K, C)`` over ``band``
    [rad/s] (module docstring): ``points`` coarse grid frequencies (0: none), the
    eigenfrequencies in the band when ``use_modes`` (over the speed, ``speed``: the
    Campbell crossings, the stiffness following the speed)."""
    t0 = time.perf_counter()
    lo, hi = band
    brackets = []  # (w, lo, hi, narrowest bracket worth a search) of every candidate
    if use_modes:
        w_r, zeta = modal_candidates(K, C, band, model, F, speed)
        half = KAPPA * np.maximum(np.abs(zeta), ZETA_FLOOR) * w_r
        brackets += [(w, w - h, w + h, h) for w, h in zip(w_r, half, strict=True)]
    else:
        w_r, zeta = np.zeros(0), np.zeros(0)
    # the narrowest resonance in the band (unknown without modes: 1e-6)
    finest = KAPPA * max(np.abs(zeta).min(initial=1e-6), ZETA_FLOOR) * lo
    setup = time.perf_counter() - t0
    solver = HarmonicSolver(K, C, comm, prefix, speed)
    a = _Amplitude(model, solver, F)
    grid = np.zeros(0)
    try:
        if points:
            grid = np.linspace(lo, hi, points) if points > 1 else np.array([lo])
            values = np.array([a(w) for w in grid])
            padded = np.concatenate([[-np.inf], values, [-np.inf]])
            for i in np.flatnonzero((values >= padded[:-2]) & (values >= padded[2:])):
                g_lo, g_hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
                if not np.any((w_r >= g_lo) & (w_r <= g_hi)):  # else a mode's bracket has it
                    brackets.append((grid[i], g_lo, g_hi, finest))
        values = [a(w) for w, _, _, _ in brackets]
        best = max(values, default=0.0)
        refined = 0
        for (_, b_lo, b_hi, narrowest), value in zip(brackets, values, strict=True):
            if value >= REFINE_RATIO * best:
                _refine(a, b_lo, b_hi, band, narrowest)
                refined += 1
        if not a.seen:  # no candidate at all: the band's centre
            a(0.5 * (lo + hi))
        w_peak = a.best()
        return PeakResponse(amplitude=a(w_peak), frequency=w_peak,
                            blade_amplitude=a.blades(w_peak).copy(), band=(lo, hi),
                            solves=solver.solves, candidates=len(brackets), modes=w_r.size,
                            refined=refined, wall_s=time.perf_counter() - t0, setup_s=setup,
                            grid=grid, grid_blade_amplitude=np.array([a.blades(w) for w in grid])
                            .reshape(grid.size, model.blades), solver=solver.settings)
    finally:
        solver.destroy()


def peak_response(model: ReducedModel, cfg: Config, band_hz, contacts: bool = True,
                  angles_deg: dict | None = None, comm=None, prefix: str = PREFIX,
                  points: int | None = None, operators_kc=None,
                  use_modes: bool = True) -> PeakResponse:
    """The peak of ``model``'s response to the nozzle of ``cfg`` over ``band_hz`` ``(lo, hi)``
    [Hz] (:func:`peak_of`); ``points``: coarse grid (None: ``forced.points``);
    ``operators_kc``: ``(K, C)`` already linearised (else :func:`forced.operators` with
    ``contacts``, ``angles_deg``, SNES prefix ``<prefix>preload_``)."""
    t0 = time.perf_counter()
    K, C = operators_kc or operators(model, cfg, contacts, angles_deg, comm, prefix)
    F = nozzle_amplitude(model, cfg.wheel.stator_vanes, cfg.excitation.force)
    band = (2 * math.pi * band_hz[0], 2 * math.pi * band_hz[1])
    points = cfg.forced.points if points is None else points
    found = peak_of(model, F, K, C, band, points, use_modes, comm, prefix,
                    speed_following(model, cfg))
    found.wall_s = time.perf_counter() - t0
    return found


def tuned_reference(model: ReducedModel, cfg: Config, deltas, contacts: bool = True,
                    angles_deg: dict | None = None, comm=None, prefix: str = PREFIX,
                    band_hz=None, points: int | None = None,
                    operators_kc=None) -> PeakResponse:
    """The tuned wheel's peak (``model`` with its mistuning removed) over the band of the
    realisations ``deltas`` (``band_hz`` [Hz] when given, else :func:`band_of`:
    ``forced.band_hz``, else automatic about the tuned resonance of ``forced.family`` at the
    excited ND); its ``band`` is the band every one of those realisations is searched over.
    ``operators_kc``: the tuned wheel's ``(K, C)`` when already linearised."""
    tuned = tuned_copy(model)
    K, C = operators_kc or operators(tuned, cfg, contacts, angles_deg, comm, prefix)
    if band_hz is None:
        centre = resonance(K, tuned, cfg.wheel.stator_vanes, cfg.forced.family,
                           speed_following(tuned, cfg))
        band = band_of(cfg, centre, deltas)
        band_hz = (band[0] / (2 * math.pi), band[1] / (2 * math.pi))
    return peak_response(tuned, cfg, band_hz, contacts, angles_deg, comm, prefix, points,
                         operators_kc=(K, C))
