"""The ``[settle]`` section: where the flutter settles (``wheelrom settle``; docs/theory.md
"Where the flutter settles", docs/usage.md)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from wheelrom.config.limits import MIN_STEP
from wheelrom.config.values import field_key as _key
from wheelrom.config.values import is_number


@dataclass(frozen=True)
class SettleConfig:
    start: str = field(
        default="cycle",
        metadata=_key("-", "'cycle': the fastest wave's exact orbit (from settle --cycles FILE, "
                      "else computed), every ND perturbed; 'preload': the preloaded "
                      "equilibrium with the growing mode of every unstable wave seeded at "
                      "seed_amplitude (slow to grow where the flutter is weak)",
                      choices=("cycle", "preload")))
    perturbation: float = field(
        default=1e-3,
        metadata=_key("-", "largest tip displacement of the perturbation of every ND, as a "
                      "fraction of the start's tip amplitude (the lowest mode of every ND, "
                      "random phases: time.perturbation's pattern)", gt=0.0, max=1.0))
    seed: int = field(
        default=0, metadata=_key("-", "seed of the perturbation's random phases", min=0))
    seed_amplitude: float = field(
        default=1e-6,
        metadata=_key("m", "tip amplitude of the unstable waves' seed (start = 'preload'; "
                      "under the elastic law at most half the fastest wave's slip onset: a "
                      "seed above the bounded state locks prestress into contacts that "
                      "then stick)", gt=0.0, max=1e-2))
    window_periods: int = field(
        default=20,
        metadata=_key("-", "periods (of the start's frequency; of a batch's lowest, "
                      "settle.batch) per stationarity window",
                      min=2, max=100000))
    tolerance: float = field(
        default=0.005,
        metadata=_key("-", "stationary: the per-blade amplitude and the ND energy distribution "
                      "change by at most this between consecutive windows", gt=0.0, max=0.5))
    consecutive: int = field(
        default=2, metadata=_key("-", "stationary windows in a row that make it settled",
                                 min=1, max=100))
    min_time: float = field(
        default=1.0,
        metadata=_key("s", "simulated time at least: long enough for the start's instability "
                      "to show (a weakly unstable cycle perturbed at 1e-3 looks stationary "
                      "for its first windows)", min=0.0, max=1e4))
    max_time: float = field(
        default=20.0,
        metadata=_key("s", "simulated time: the run ends with the window ending nearest it "
                      "(up to half a window past it); then 'not settled after X s "
                      "(settle.max_time)' with the range and trend over the last bounded_span",
                      gt=0.0, max=1e4))
    bounded_span: float = field(
        default=3.0,
        metadata=_key("s", "a motion that does not become stationary is bounded, and its run "
                      "ends, once the trend of its largest amplitude over the last "
                      "bounded_span (all after min_time) keeps it within bounded_drift at "
                      "about 95 % (the error adjusted for the windows' correlation)",
                      gt=0.0, max=1e4))
    bounded_drift: float = field(
        default=0.05,
        metadata=_key("-", "largest drift of the amplitude over bounded_span, relative, that "
                      "still counts as bounded", gt=0.0, max=1.0))
    batch: int = field(
        default=3,
        metadata=_key("-", "cases integrated together in one TS (cases of the same wheel and "
                      "settings, in the order of the study; the kernel vectorises across them: "
                      "0.56-0.61 of a lone case's time per case at 2-3 cases on the paper "
                      "wheel, 0.72-0.76 with both cores of a 2-core machine busy). A batch "
                      "shares its windows: window_periods periods of its cases' lowest start "
                      "frequency. The batches, not the MPI ranks, "
                      "decide them: the results do not depend on the number of ranks",
                      min=1, max=1000))
    step: float = field(
        default=0.0,
        metadata=_key("s", "the settle's own fixed time step (0: time.step): its amplitude "
                      "statistics hold at a coarser step than a seed's growth rate needs "
                      "(the paper wheel's flutter at 20 us reads 10 us's and 5 us's within "
                      "their window-to-window scatter: docs/performance.md); the exponential "
                      "scheme's stability check may lower it (the paper wheel: 20 us to 18; "
                      "the elastic law: to 8.1 us), and the settle reports the step taken",
                      min=0.0, max=1e-3))
    nozzle: bool = field(
        default=False,
        metadata=_key("-", "nozzle excitation on (excitation.force; windows a whole number of "
                      "nozzle periods)"))


def at_settle_step(cfg: Any) -> Any:
    """``cfg`` integrated at ``settle.step`` where it is set (0: ``time.step``): the settle's
    own step, for its amplitude statistics, not a seed's growth rate."""
    return cfg.replace(**{"time.step": cfg.settle.step}) if cfg.settle.step > 0 else cfg


def settle_problems(cfg: Any, problems: list[str]) -> None:
    """Cross-checks of ``[settle]``: what the keys alone show. The window's length is known
    only with the start's frequency (:func:`wheelrom.analysis.periodic.settle.settle_cases`
    checks it against ``max_time`` before integrating)."""
    s = cfg.settle
    if is_number(s.step) and 0 < s.step < MIN_STEP:
        problems.append(f"settle.step = {s.step:g} s is below the smallest step, "
                        f"{MIN_STEP:g} s (0: time.step)")
    if is_number(s.min_time) and is_number(s.max_time) and s.min_time > s.max_time:
        problems.append(f"settle.min_time = {s.min_time:g} s is above settle.max_time = "
                        f"{s.max_time:g} s: no case could ever be called settled")
