"""Friction-held limit cycles of one case, per travelling wave: where each wave's Hopf point
is (the factor ``lam_c`` on the self-excitation at which it crosses), the branch of periodic
solutions from there by pseudo-arclength continuation in ``lam`` (the amplitude-dependent
frequency and damping of the wave's nonlinear mode), the cycles at the configured intensity
(``lam = 1``), each made exact by shooting (``limit_cycle.method = "shooting"``:
:func:`~.exact.exact_cycle`; under the elastic law the orbit is marched and shot without a
balance, :func:`~.exact.marched_cycle`), and their Floquet stability (docs/theory.md,
"Limit cycles").

The autonomous problem: nozzle off, tuned wheel, around the case's preloaded equilibrium
(:func:`wheelrom.analysis.stability.linearise`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np

from wheelrom.analysis.periodic.continuation import BranchSettings, Corrector, Point, trace
from wheelrom.analysis.periodic.cycle import (
    UNRESOLVED,
    Cycle,
    coexisting,
    describe,
    orbit_words,
    whole_wheel_words,
)
from wheelrom.analysis.periodic.cycle_transient import transient_stability
from wheelrom.analysis.periodic.exact import exact_cycle, marched_cycle, monodromy_stability
from wheelrom.analysis.periodic.floquet import floquet
from wheelrom.analysis.periodic.harmonic_balance import WaveBalance
from wheelrom.analysis.periodic.hopf import GROWTH_TOLERANCE, hopf_point, wave_blocks, wave_mode
from wheelrom.analysis.stability import linearise
from wheelrom.config import Config
from wheelrom.forces.parameters import VDP_OFF
from wheelrom.rom.model import ReducedModel, nodal_diameter
from wheelrom.runtime.errors import InputError

FASTEST = -1  # in Settings.waves: the wave growing fastest at the configured intensity
START_AMPLITUDE = 1e-9  # [m] tip amplitude of the first cycle next to the Hopf point
FINE_SAMPLES = 256  # time samples per period of the reported quantities
SEED_HARMONICS = 3  # harmonics of the first Newton solve of a seed that fails with H


@dataclass(frozen=True)
class Settings:
    """The ``[limit_cycle]`` keys (docs/usage.md)."""

    harmonics: int = 7
    samples: int = 0  # 0: 8 (H + 1)
    waves: tuple = ()  # travelling-wave indices k (0..N-1); (): every unstable one
    floquet: str = "auto"  # 'auto': 'monodromy' for shooting, 'cycles' for 'hb'; 'cycles':
    # Hill, every family at the cycles; 'all': also the wave's own family along the branches;
    # 'monodromy', 'transient', 'off'
    method: str = "hb"  # 'shooting': HB cycles polished into exact orbits (the configuration's
    # default, limit_cycle.method); 'hb': the harmonic balance alone
    multipliers: int = 10  # monodromy multipliers of largest modulus
    refine: int = 4  # step halvings of the in-symmetry multiplier check
    whole_wheel: str = "always"  # 'undecided': the whole wheel's only when the above has not
    seeds: tuple = (1e-6, 1e-5, 1e-4, 1e-3)  # [m] tip amplitudes of the Newton starts at lam = 1
    branch: BranchSettings = field(default_factory=BranchSettings)

    @property
    def time_samples(self) -> int:
        return self.samples or 8 * (self.harmonics + 1)


def settings_of(cfg: Config, waves=None) -> Settings:
    """The :class:`Settings` of ``cfg.limit_cycle``; ``waves`` (e.g. ``--nd``) overrides
    ``limit_cycle.waves``."""
    lc = cfg.limit_cycle
    branch = BranchSettings(lam_max=lc.mu_max, amplitude_max=lc.amplitude_max, steps=lc.steps)
    # the elastic law's balance: Hill's method would read the hysteresis's local tangent only
    # (its exact orbit's multipliers are the pattern map's: exact.elastic_stability)
    floquet = "off" if cfg.contacts.elastic and lc.floquet == "auto" \
        and lc.method != "shooting" else lc.floquet
    return Settings(harmonics=lc.harmonics, samples=lc.samples,
                    waves=tuple(lc.waves if waves is None else waves), floquet=floquet,
                    seeds=tuple(lc.seeds), branch=branch, method=lc.method,
                    multipliers=lc.multipliers, refine=lc.refine,
                    whole_wheel=lc.whole_wheel)


def floquet_kind(settings: Settings) -> str:
    """The stability method in effect (``floquet = 'auto'`` resolved)."""
    if settings.floquet != "auto":
        return settings.floquet
    return "monodromy" if settings.method == "shooting" else "cycles"


@dataclass
class WaveBranch:
    """The limit cycles of wave ``wave`` (blade ``s + 1`` leads by ``2 pi wave / N``):
    ``nodal_diameter``, ``direction`` (+1 forward: the wave index is the ND, -1 backward);
    ``critical_lam``: its Hopf point (``nan``: none up to ``mu_max``), ``hopf_hz``;
    ``points``: the branches, ``segments`` the branch of each point (0: from the Hopf point,
    then two per cycle found from a seed, one each way in ``lam``); ``folds``: indices of
    turning points; ``end``: why the branch
    ends, in words; ``cycles``: the solutions at ``lam = 1``; ``note``: why there is no branch."""

    wave: int
    nodal_diameter: int
    direction: int
    critical_lam: float
    hopf_hz: float
    points: list[Cycle] = field(default_factory=list)
    segments: list[int] = field(default_factory=list)
    folds: list[int] = field(default_factory=list)
    end: str = ""
    cycles: list[Cycle] = field(default_factory=list)
    note: str = ""
    wall_s: float = 0.0
    kinds: tuple = ()  # the contact kinds, in the order of ``fractions``

    def verdict(self) -> str:
        """What the wave does at the configured intensity, in words."""
        if self.note:
            return self.note
        if not self.cycles and self.critical_lam > 1.0:
            return (f"stable at the configured intensity (Hopf at {self.critical_lam:.3g} x mu; "
                    "no cycle there)")
        if not self.cycles and not self.points:  # the elastic law's march and shot
            return f"no exact orbit found ({self.end})"
        if not self.cycles:
            top = max((p.tip_amplitude for p in self.points), default=0.0)
            return f"no bounded cycle below {top * 1e6:.3g} um tip ({self.end})"
        stable = [c for c in self.cycles if c.stable]
        c = min(stable or self.cycles, key=lambda c: c.tip_amplitude)
        lead = "settles at" if c.stable else "limit cycle at"
        elastic = getattr(c.orbit, "sliders", None) is not None  # the elastic law's orbit
        words = [f"{lead} {c.tip_amplitude * 1e6:.3g} um tip, {c.frequency_hz:.4g} Hz"]
        if c.shot_missed:  # the number is the harmonic balance's, not the exact orbit's
            words[0] += f" by {c.source}"
        for k, kind in enumerate(self.kinds):
            open_, _, slip = c.fractions[k]
            words.append(f"{kind} open {100 * open_:.0f} %"
                         + (f", slipping {100 * slip:.0f} %" if slip > 0 else ""))
        if c.energy_residual > UNRESOLVED:
            words.append(f"poorly resolved (energy balance off by {c.energy_residual:.2g}: "
                         "more limit_cycle.harmonics and samples)")
        if c.stability is None:
            words.append("stability not computed" + (f" ({c.floquet_skipped})"
                                                      if c.floquet_skipped else ""))
        elif c.stable is None and c.multipliers is not None and not len(c.multipliers.values):
            words.append("stability not decided (SLEPc converged no multiplier of the whole "
                         "wheel within its restarts: -limitcycle_floquet_eps_max_it)")
        elif c.stable is None and elastic:  # in words: stable in symmetry only, or uncertain
            words.append(c.stability.by)
        elif c.stable is None:
            how = "the monodromy" if c.multipliers is not None else \
                "Hill's method on a cycle with contacts opening"
            words.append(f"stability uncertain ({how}: the phase-shift multiplier is off 1 by "
                         f"{c.stability.trivial:.1e}, the largest is {c.stability.multiplier:.4g})")
        elif not c.stable:
            st = c.stability
            inside = st.by.startswith("monodromy inside")  # proved in the cycle's symmetry
            if c.multipliers is not None or inside:
                whole = whole_wheel_words(c)
                alone = "the flutter does not settle on this wave alone"
                if inside:
                    step = c.refined[-1][0]
                    words.append(f"unstable inside its own symmetry (ND {st.worst_family}: "
                                 f"multiplier {st.multiplier:.5g} per period at a "
                                 f"{step * 1e6:.2g} us step; {whole}; "
                                 f"{alone})")
                else:
                    words.append(f"unstable (monodromy: {whole}; {alone})")
            else:
                words.append(f"unstable ({st.by} {st.worst_family} grows at "
                             f"{st.growth.max():.3g} /s; the flutter does not settle on this "
                             "wave alone)")
        words += [orbit_words(c), coexisting(self.cycles, c)]
        if c.band is not None:
            words.append(c.band.words())
        return ", ".join(w for w in words if w)


@dataclass
class CaseLimitCycles:
    """The limit cycles of one case: ``angles_deg``, ``equilibrium`` ``(N, m)``, ``branches``
    (one per wave analysed), ``wall_s``."""

    angles_deg: dict
    kinds: tuple
    equilibrium: np.ndarray
    branches: list[WaveBranch]
    wall_s: float
    failure: str = ""  # why the case has no result (its equilibrium failed, ...)
    parameters: dict = field(default_factory=dict)  # the study's varied keys -> values
    # the linear analysis's fastest-growing wave at the configured intensity, when it grows:
    # (wave, ND, growth rate [1/s]); None: every wave is stable
    fastest: tuple | None = None

    def verdict(self) -> str:
        if self.failure:
            return f"failed: {self.failure}"
        flutter = [b for b in self.branches if b.cycles or not (b.note or b.critical_lam > 1.0)]
        hopf = [b.critical_lam for b in self.branches if b.critical_lam > 1.0]
        at = f" (Hopf at {min(hopf):.3g} x mu)" if hopf else ""
        if not flutter and self.fastest and self.fastest[0] not in {b.wave for b in self.branches}:
            # only the waves asked (--nd) were examined: stable they are, the case is not
            k, nd, rate = self.fastest
            asked = ", ".join(str(b.nodal_diameter) for b in self.branches)
            one = len(self.branches) == 1
            return (f"the wave{'' if one else 's'} asked (ND {asked}) {'is' if one else 'are'} "
                    f"stable at the configured intensity{at}, but the case flutters: its "
                    f"fastest wave, ND {nd} (wave {k}, growing at {rate:.3g} /s), was not "
                    "examined")
        if not flutter:
            return f"stable at the configured intensity{at}" if hopf else "stable"
        worst = max(flutter, key=lambda b: max((c.tip_amplitude for c in b.cycles),
                                               default=math.inf))
        return f"flutters (ND {worst.nodal_diameter}): {worst.verdict()}"


class WaveAnalysis:
    """The branches of one wave: from its Hopf point, and from cycles found at ``lam = 1``
    by Newton from a ladder of amplitudes (a branch from the Hopf point may end where a
    contact starts to touch or lift off within the cycle, a grazing point; the large cycles
    beyond are reached from above); the cycles at ``lam = 1`` and their Floquet stability."""

    def __init__(self, model, params, beta, q_eq, blocks, settings: Settings, comm=None,
                 progress=None, cfg: Config | None = None,
                 angles: dict | None = None):
        self.model, self.params, self.beta, self.q_eq = model, params, beta, q_eq
        self.B0, self.B1 = blocks
        self.settings, self.comm, self.progress = settings, comm, progress
        self.cfg, self.angles = cfg, angles  # the case, for the transient stability check

    def run(self, wave: int) -> WaveBranch:
        t0 = time.perf_counter()
        N, st = self.model.blades, self.settings
        nd = int(nodal_diameter(wave, N))
        branch = WaveBranch(wave, nd, 1 if wave <= N // 2 else -1, math.nan, math.nan,
                            kinds=self.params.contacts.kinds)
        lam_c = hopf_point(self.B0[wave], self.B1[wave], st.branch.lam_max)
        branch.critical_lam = lam_c
        if math.isnan(lam_c):
            branch.note = f"stable up to {st.branch.lam_max:g} x mu (no Hopf point)"
        elif self.params.law.elastic and st.method == "shooting":  # no balance: it stalls
            say = self.progress and (lambda tip: self.progress(wave, 1.0, tip))
            marched_cycle(self.model, self.cfg, self.angles, branch, self.q_eq,
                          (self.B0[wave], self.B1[wave]), st.harmonics, say,
                          None if floquet_kind(st) == "off" else st.refine,
                          st.whole_wheel, st.multipliers)
        else:  # lam_c = 0: unstable without self-excitation, no Hopf branch; seeds still
            self._branches(branch, wave, lam_c)
        branch.wall_s = time.perf_counter() - t0
        return branch

    def _branches(self, branch: WaveBranch, wave: int, lam_c: float) -> None:
        st, m = self.settings, self.model.modes
        _, value, vector = wave_mode(self.B0[wave], self.B1[wave], lam_c if lam_c > 0 else 1.0)
        omega_c = float(value.imag)
        branch.hopf_hz = omega_c / (2 * math.pi)
        v = vector[:m]
        v = v / np.linalg.norm(v @ self.model.tip.T)  # 1 m of tip amplitude
        j = int(np.argmax(np.abs(v)))
        v = v * np.exp(-1j * np.angle(v[j]))
        balance = WaveBalance(self.model, self.params, self.beta, wave, st.harmonics,
                              st.time_samples)
        fine = WaveBalance(self.model, self.params, self.beta, wave, st.harmonics,
                           max(FINE_SAMPLES, st.time_samples))
        x_scale = np.full(2 * st.harmonics + 1, 1e-6 * float(np.abs(v).max()))  # 1 ~ 1 um
        x_scale[0] = max(float(np.abs(self.q_eq[0]).max()), x_scale[1])  # static deflection
        corrector = Corrector(balance, x_scale, omega_c, 2 * m + j, self.comm)
        say = self._say(wave)
        try:
            amplitude_axis = np.zeros(balance.size + 2)
            amplitude_axis[m + j] = 1.0
            segments = []
            first = None if lam_c == 0 else corrector.solve(
                self._guess(corrector, v, START_AMPLITUDE, omega_c, lam_c), amplitude_axis,
                START_AMPLITUDE / x_scale[1] * v[j].real)
            if lam_c == 0:
                branch.end = "no Hopf point: unstable without self-excitation"
            elif first is None:
                branch.end = "Newton failed next to the Hopf point"
            else:
                points, branch.end = trace(corrector, first, amplitude_axis, st.branch,
                                           self._amplitude, say)
                segments.append(points)
            lam_axis = np.zeros(balance.size + 2)
            lam_axis[-1] = 1.0
            for amplitude in st.seeds:
                seed = self._seed(corrector, v, amplitude, omega_c, j)
                if seed is None or not corrector.plausible(seed) or \
                        self._amplitude(seed) < 10 * START_AMPLITUDE or \
                        self._known(self._amplitude(seed), segments):
                    continue
                half = dataclasses.replace(st.branch, steps=max(2, st.branch.steps // 10))
                for direction in (lam_axis, -lam_axis):
                    points, _ = trace(corrector, seed, direction, half, self._amplitude, say)
                    segments.append(points)
            self._report(branch, corrector, balance, fine, segments)
        finally:
            corrector.destroy()

    def _known(self, amplitude: float, segments: list[list[Point]]) -> bool:
        """Whether a cycle of tip amplitude ``amplitude`` [m] at ``lam = 1`` lies on a branch
        already traced: within 1e-3 of one of its points, or between the two points where it
        crosses ``lam = 1`` (a seed that lands between them is that crossing's cycle: traced
        again both ways it only repeats the branch, 24 points)."""
        for points in segments:
            a = np.array([self._amplitude(p) for p in points])
            lam = np.array([p.lam for p in points])
            if np.any(np.abs(amplitude - a) <= 1e-3 * a):
                return True
            for i in crossings(lam):
                lo, hi = sorted((a[i], a[i + 1]))
                if lo * (1 - 1e-3) <= amplitude <= hi * (1 + 1e-3):
                    return True
        return False

    def _seed(self, corrector: Corrector, v, amplitude: float, omega: float,
              j: int) -> Point | None:
        """The cycle at ``lam = 1`` by Newton from the linear mode at ``amplitude`` [m]; when
        that fails with many harmonics, first with :data:`SEED_HARMONICS` and then from that
        solution (a single-harmonic guess is far from a cycle whose contacts open)."""
        b = corrector.balance
        lam_axis = np.zeros(corrector.n)
        lam_axis[-1] = 1.0
        seed = corrector.solve(self._guess(corrector, v, amplitude, omega, 1.0), lam_axis, 1.0)
        if seed is not None or b.H <= SEED_HARMONICS:
            return seed
        low = WaveBalance(self.model, self.params, self.beta, b.wave, SEED_HARMONICS,
                          8 * (SEED_HARMONICS + 1))
        X = np.zeros((2 * SEED_HARMONICS + 1, b.modes))
        X[0], X[1], X[2] = self.q_eq[0], amplitude * v.real, amplitude * v.imag
        first = periodic_solution(low, X, omega, 1.0, self.comm)
        if first is None:
            return None
        c = np.zeros((b.H + 1, b.modes), dtype=complex)
        c[: SEED_HARMONICS + 1] = low.complex_harmonics(first.X)
        c *= np.exp(-1j * np.angle(c[1, j]) * np.arange(b.H + 1))[:, None]  # Im c_1[j] = 0
        return corrector.solve(corrector.pack(b.packed(c), first.omega, 1.0), lam_axis, 1.0)

    def _guess(self, corrector, v, amplitude, omega, lam) -> np.ndarray:
        """The equilibrium plus the linear mode ``v`` (unit tip amplitude) at ``amplitude``
        [m] as harmonic 1."""
        b = corrector.balance
        X = np.zeros((2 * b.H + 1, b.modes))
        X[0] = self.q_eq[0]
        X[1], X[2] = amplitude * v.real, amplitude * v.imag
        return corrector.pack(X, omega, lam)

    def _say(self, wave):
        if self.progress is None:
            return None
        return lambda p: self.progress(wave, p.lam, self._amplitude(p))

    def _amplitude(self, point: Point) -> float:
        """Tip amplitude of harmonic 1 [m] (the branch's measure; the reported 0-peak comes
        from the whole motion)."""
        c1 = point.X[1] + 1j * point.X[2]
        return float(np.linalg.norm(np.abs(self.model.tip @ c1)))

    def _report(self, branch, corrector, balance, fine, segments: list[list[Point]]) -> None:
        st = self.settings
        e = np.zeros(corrector.n)
        e[-1] = 1.0
        found: list[Point] = []
        for number, points in enumerate(segments):
            lam = np.array([p.lam for p in points])
            dlam = np.diff(lam)
            offset = len(branch.points)
            branch.folds += [offset + i for i in range(1, len(points) - 1)
                             if dlam[i - 1] * dlam[i] < 0]
            for p in points:
                cycle = describe(balance, fine, p.X, p.omega, p.lam, self._residual(balance, p))
                if st.floquet == "all":
                    cycle.stability = floquet(balance, corrector.linearisation(p), p.omega,
                                              p.lam)
                branch.points.append(cycle)
                branch.segments.append(number)
            for i in crossings(lam):
                if points[i].lam == 1.0 or points[i + 1].lam == 1.0:
                    p = points[i] if points[i].lam == 1.0 else points[i + 1]
                else:
                    w = (1.0 - lam[i]) / (lam[i + 1] - lam[i])
                    guess = (1 - w) * points[i].z + w * points[i + 1].z
                    p = corrector.solve(guess, e, 1.0)
                    if p is not None and np.linalg.norm(p.z - guess) > np.linalg.norm(
                            points[i + 1].z - points[i].z):
                        p = None  # landed on another branch
                if p is not None and corrector.plausible(p) and \
                        self._amplitude(p) > 10 * START_AMPLITUDE and not any(
                        abs(self._amplitude(p) - self._amplitude(f)) <= 1e-6 * self._amplitude(f)
                        for f in found):
                    found.append(p)
        kind = floquet_kind(st)
        for p in sorted(found, key=self._amplitude):
            cycle = describe(balance, fine, p.X, p.omega, p.lam, self._residual(balance, p))
            if st.method == "shooting":
                cycle = exact_cycle(self.model, self.cfg, self.angles, branch, balance, p.X,
                                    p.omega, cycle, st.harmonics, self.comm)
            if kind == "monodromy" and cycle.orbit is not None:
                monodromy_stability(self.model, self.cfg, self.angles, cycle, st.multipliers,
                                    st.refine, self.comm, st.whole_wheel)
            elif st.floquet == "transient":
                cycle.stability = transient_stability(self.model, self.cfg, self.angles,
                                                      balance, p.X, p.omega, p.lam,
                                                      cycle.tip_amplitude)
            elif kind == "monodromy" and cycle.fractions[:, 0].max() > 0:
                # the shot missed a cycle whose contacts open: Hill's method does not converge
                # on it (docs/theory.md), 60 s on the paper's wheel to say "uncertain"
                cycle.floquet_skipped = "Hill's method does not converge on a cycle whose " \
                    "contacts open; limit_cycle.floquet = 'transient' decides it"
            elif kind != "off":  # Hill's method (also a "monodromy" cycle shooting missed)
                cycle.stability = floquet(balance, corrector.linearisation(p), p.omega, p.lam,
                                          range(self.model.blades))
            branch.cycles.append(cycle)

    @staticmethod
    def _residual(balance: WaveBalance, p: Point) -> float:
        linear = balance.linear_term(p.X, p.omega, p.lam)
        R = linear - balance.P @ balance.nonlinear_force(p.X, p.omega, p.lam)
        return float(np.abs(R).max() / max(np.abs(linear).max(), 1e-300))


def crossings(lam: np.ndarray) -> np.ndarray:
    """Indices ``i`` of a branch's factors ``lam`` ``(P,)`` between whose points ``i`` and
    ``i + 1`` the branch crosses ``lam = 1`` (the configured intensity)."""
    return np.flatnonzero((lam[:-1] - 1.0) * (lam[1:] - 1.0) <= 0)


def periodic_solution(balance: WaveBalance, X: np.ndarray, omega: float, lam: float = 1.0,
                      comm=None) -> Point | None:
    """Newton (SNES, prefix ``limitcycle_``) at the fixed factor ``lam`` from the guess
    ``X`` ``(2H + 1, m)``, ``omega`` [rad/s]: the cycle, or ``None`` when Newton fails. The
    phase is fixed on the largest component of ``c_1`` of the guess."""
    m = balance.modes
    c1 = X[1] + 1j * X[2]
    j = int(np.argmax(np.abs(c1)))
    X = balance.packed(balance.complex_harmonics(X) * np.exp(-1j * np.angle(c1[j]) *
                                                             np.arange(balance.H + 1))[:, None])
    x_scale = np.full(2 * balance.H + 1, float(np.abs(c1).max()))
    x_scale[0] = max(float(np.abs(X[0]).max()), x_scale[1])
    corrector = Corrector(balance, x_scale, omega, 2 * m + j, comm)
    try:
        lam_axis = np.zeros(corrector.n)
        lam_axis[-1] = 1.0
        point = corrector.solve(corrector.pack(X, omega, lam), lam_axis, lam)
        if point is not None:
            corrector.linearisation(point)
        return point
    finally:
        corrector.destroy()


def case_limit_cycles(model: ReducedModel, cfg: Config, settings: Settings,
                      angles_deg: dict | None = None, comm=None,
                      progress=None) -> CaseLimitCycles:
    """The limit cycles of one case (contact angles ``angles_deg``) at every wave of
    ``settings.waves`` or, by default, every wave whose linearisation grows at ``lam = 1``.
    ``progress(wave, lam, tip_amplitude)`` is called at every branch point."""
    t0 = time.perf_counter()
    if cfg.flutter.model == "off" or (cfg.flutter.model != "table" and cfg.flutter.mu <= 0):
        raise InputError("limit cycles need self-excitation: flutter.model = 'off' or "
                         "flutter.mu = 0 leaves the equilibrium the only periodic state")
    params, q, _, J, _ = linearise(model, cfg, angles_deg, comm)
    if params.vdp_model == VDP_OFF:
        raise InputError("limit cycles need self-excitation (flutter.model)")
    blocks = wave_blocks(model, params, q, J)
    growth = np.array([wave_mode(blocks[0][k], blocks[1][k], 1.0)[0]
                       for k in range(model.blades)])
    waves = [k for k in settings.waves if k != FASTEST]
    if FASTEST in settings.waves and growth.max() > GROWTH_TOLERANCE:
        waves.append(int(np.argmax(growth)))
    if not settings.waves:
        waves = [int(k) for k in np.flatnonzero(growth > GROWTH_TOLERANCE)]
    waves = sorted(set(waves))
    analysis = WaveAnalysis(model, params, cfg.wheel.damping_beta, q, blocks, settings, comm,
                            progress, cfg, angles_deg)
    branches = [analysis.run(k) for k in waves]
    k = int(np.argmax(growth))
    fastest = (k, int(nodal_diameter(k, model.blades)), float(growth[k])) \
        if growth[k] > GROWTH_TOLERANCE else None
    return CaseLimitCycles(
        angles_deg={k: float(np.atleast_1d(v)[0]) for k, v in params.contacts.angles_deg.items()},
        kinds=params.contacts.kinds, equilibrium=q, branches=branches,
        wall_s=time.perf_counter() - t0, fastest=fastest)
