"""The ``[limit_cycle]`` section: the travelling waves' limit cycles (``wheelrom
limit-cycle``): the harmonic balance and its continuation that find them, the exact orbit by
shooting and its Floquet stability (docs/theory.md "Limit cycles", docs/usage.md)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from wheelrom.config.values import field_key as _key


@dataclass(frozen=True)
class LimitCycleConfig:
    harmonics: int = field(
        default=7, metadata=_key("-", "harmonics H of the harmonic balance", min=1, max=64))
    samples: int = field(
        default=0,
        metadata=_key("-", "time samples per period of the AFT force evaluation; 0 = 8 (H + 1) "
                      "(at least 2 H + 1; 4 H + 1 resolves the Floquet analysis; a contact "
                      "that opens within the cycle wants more)", min=0, max=4096))
    method: str = field(
        default="shooting",
        metadata=_key("-", "'shooting': the exact periodic orbit (shooting on the transient's "
                      "TS from the harmonic-balance cycle; the answer), 'hb': the harmonic "
                      "balance alone (seconds; on cycles whose contacts open its amplitude "
                      "is 2-8.5 % high at H = 11, truncation that closes near H = 60: "
                      "docs/results.md)", choices=("shooting", "hb")))
    multipliers: int = field(
        default=10,
        metadata=_key("-", "Floquet multipliers of largest modulus of the whole wheel "
                      "reported (floquet = 'monodromy'; SLEPc computes that many, Bloch waves "
                      "every one)", min=1, max=200))
    whole_wheel: str = field(
        default="always",
        metadata=_key("-", "the whole wheel's monodromy multipliers (floquet = 'monodromy'): "
                      "'always', or 'undecided': only when the dominant multiplier inside the "
                      "cycle's own symmetry at the refined steps does not already prove it "
                      "unstable (the whole wheel's then adds the ND the flutter grows in, at "
                      "time.step, which resolves a cycle whose contacts open to first order "
                      "only; every ND's by Bloch waves for an orbit whose pattern is smaller "
                      "than the wheel, 6 s per paper angle, else SLEPc's, 15-20 s; under the "
                      "elastic law at the two finest refined steps, 10-45 s)",
                      choices=("always", "undecided")))
    refine: int = field(
        default=4,
        metadata=_key("-", "step halvings at which the dominant multiplier inside the "
                      "cycle's own symmetry is recomputed (with limit_cycle.events they "
                      "converge at the scheme's order, without at first order in time.step; "
                      "docs/theory.md)", min=0, max=6))
    events: bool = field(
        default=True,
        metadata=_key("-", "the multipliers on a step schedule that ends a piece at each of "
                      "the orbit's contact switches (lift-off, closing, the elastic law's "
                      "stick and slip; located once an orbit, about a second on the paper "
                      "wheel) with each contact held on its branch in between, so that they "
                      "converge at the scheme's order (docs/theory.md 'Events in the "
                      "step'); false: uniform steps across the switches (first order)"))
    waves: tuple[int, ...] = field(
        default=(-1,),
        metadata=_key("-", "travelling waves k (blade s+1 leads by 2 pi k / N; 0..N-1) whose "
                      "limit cycles are computed, -1 = the fastest-growing one; [] = every wave "
                      "unstable at the configured intensity", min=-1, integers=True,
                      allow_empty=True))
    mu_max: float = field(
        default=4.0,
        metadata=_key("-", "continuation stops where the factor on the self-excitation "
                      "(flutter.mu or flutter.table_scale) exceeds this", gt=0.0, max=1e3))
    amplitude_max: float = field(
        default=1e-3,
        metadata=_key("m", "continuation stops above this tip amplitude; 'no bounded cycle "
                      "below' it is reported when none is found", gt=0.0, max=1.0))
    steps: int = field(
        default=120, metadata=_key("-", "most points of the branch from the Hopf point", min=2,
                                   max=100_000))
    seeds: tuple[float, ...] = field(
        default=(1e-6, 1e-5, 1e-4, 1e-3),
        metadata=_key("m", "tip amplitudes of the Newton starts at the configured intensity "
                      "(each cycle found is continued both ways); [] = the Hopf branch only",
                      gt=0.0, max=1.0, allow_empty=True))
    band: bool = field(
        default=True,
        metadata=_key("-", "under the elastic law, trace the family of friction-limited orbits "
                      "over the admissible slider offsets of the contacts stuck the whole "
                      "period and report its band, the smallest and largest amplitude "
                      "(docs/theory.md 'Why the friction-limited amplitude is a band'; "
                      "15-50 s an orbit of the paper wheel with its multipliers)"))
    floquet: str = field(
        default="auto",
        metadata=_key("-", "stability of the cycles: 'auto' ('monodromy' for shooting, "
                      "'cycles' for 'hb'), 'monodromy' (Floquet multipliers of the whole "
                      "wheel about the exact orbit: every ND's by Bloch waves, or SLEPc's on "
                      "the monodromy where the orbit's pattern is the wheel), 'cycles' (Floquet by "
                      "Hill's method, every "
                      "Bloch family, at the cycles of the configured intensity), 'all' (also "
                      "the wave's own family at every branch point: the branch drawn "
                      "stable/unstable), 'transient' (the wheel integrated 60 periods from "
                      "each cycle with every other ND perturbed: for cycles whose contacts "
                      "open, where Hill's method does not converge), 'off'",
                      choices=("auto", "monodromy", "all", "cycles", "transient", "off")))


def limit_cycle_problems(cfg: Any, problems: list[str]) -> None:
    """Cross-checks of ``[limit_cycle]`` against the wheel."""
    lc = cfg.limit_cycle
    if not all(isinstance(v, int) for v in (lc.samples, lc.harmonics, cfg.wheel.blades)):
        return  # a type problem, already named
    if lc.samples and lc.samples < 2 * lc.harmonics + 1:
        problems.append(f"limit_cycle.samples = {lc.samples}: at least 2 H + 1 = "
                        f"{2 * lc.harmonics + 1} samples per period are needed (0 = 8 (H + 1))")
    bad = [k for k in lc.waves if isinstance(k, int) and k >= cfg.wheel.blades]
    if bad:
        problems.append(f"limit_cycle.waves: {bad} not below wheel.blades = {cfg.wheel.blades}")
