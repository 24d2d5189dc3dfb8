"""``bench``'s same-run cost ratios, one core: the elastic Coulomb contact against the paper's
law (issue #44: an elastic-law transient at most 1.5x the paper law's per simulated second)
and the settle's step against ``time.step`` (issue #70):

- ``law_s_per_simulated_s``: ``{"paper": [min, median], "elastic": [min, median]}`` seconds
  of integration per simulated second of the configured case (its scheme and step; each law
  takes the step its TS takes, the elastic law's lowered to its stable step), 20.16 ms from
  each law's preloaded equilibrium with a 1 nm seed, the two laws alternated ``ROUNDS`` times
  (one run each is too noisy on a shared machine: 10-30 % run to run);
- ``elastic_vs_paper``: ``[min, median]`` the elastic law's over the paper law's;
- ``law_steps_s``: each law's step [s];
- ``settle_s_per_simulated_s`` (issue #70: the settle at the step its statistics allow):
  ``{"time_step": [min, median], "settle_step": [min, median]}`` the same for the
  configured law at ``time.step`` and at the settle's step (``settle.step``, or
  :data:`SETTLE_FACTOR` times ``time.step`` as ``./run/paper`` asks where it is 0), each at
  the step its TS takes (``settle_steps_s``), alternated the same way;
  ``settle_speedup`` ``[min, median]`` the first over the second: the settle's same-run
  ratio (its accuracy, the settled amplitude's statistics against a finer step's, is
  docs/performance.md's "The settle's step").
"""

from __future__ import annotations

import numpy as np

from wheelrom.config import Config
from wheelrom.forces.parameters import force_parameters
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime.environment import petsc
from wheelrom.transient.preload import initial_state
from wheelrom.transient.problem import WheelProblem
from wheelrom.transient.run import run_case

ROUNDS = 6
END = 0.02016  # [s] as the scheme figures' runs (bench.transient)
LAWS = ("paper", "elastic")
#: the settle's step over time.step where settle.step is 0 (./run/paper: 20 us against 10)
SETTLE_FACTOR = 2.0


def law_figures(model: ReducedModel, cfg: Config, say, rounds: int = ROUNDS,
                end: float = END) -> dict:
    """The law figures above (``say``: progress lines; ``rounds`` alternations of runs over
    ``end`` [s] of simulated time)."""
    figures, steps = alternated(model, {law: cfg.replace(**{"contacts.law": law})
                                        for law in LAWS}, rounds, end)
    ratio = [figures["elastic"][0] / figures["paper"][0],
             figures["elastic"][1] / figures["paper"][1]]
    say(f"laws: paper {figures['paper'][0]:.2f} / {figures['paper'][1]:.2f}, elastic "
        f"{figures['elastic'][0]:.2f} / {figures['elastic'][1]:.2f} s per simulated s (min / "
        f"median of {rounds}): {ratio[0]:.2f}x / {ratio[1]:.2f}x")
    return {"law_s_per_simulated_s": figures, "elastic_vs_paper": ratio,
            "law_steps_s": steps}


def settle_figures(model: ReducedModel, cfg: Config, say, rounds: int = ROUNDS,
                   end: float = END) -> dict:
    """The settle figures above: the configured case at ``time.step`` against the settle's
    step, ``rounds`` alternations over ``end`` [s]."""
    step = cfg.settle.step if cfg.settle.step > 0 else SETTLE_FACTOR * cfg.time.step
    figures, steps = alternated(model, {"time_step": cfg,
                                        "settle_step": cfg.replace(**{"time.step": step})},
                                rounds, end)
    ratio = [figures["time_step"][0] / figures["settle_step"][0],
             figures["time_step"][1] / figures["settle_step"][1]]
    say(f"settle's step: {steps['settle_step'] * 1e6:.3g} us (asked {step * 1e6:.3g}) "
        f"{figures['settle_step'][0]:.2f} / {figures['settle_step'][1]:.2f} s per simulated s "
        f"against {figures['time_step'][0]:.2f} / {figures['time_step'][1]:.2f} at "
        f"{steps['time_step'] * 1e6:.3g} us: {ratio[0]:.2f}x / {ratio[1]:.2f}x")
    return {"settle_s_per_simulated_s": figures, "settle_speedup": ratio,
            "settle_steps_s": steps}


def alternated(model: ReducedModel, variants: dict, rounds: int, end: float
               ) -> tuple[dict, dict]:
    """``({name: [min, median]}, {name: step})``: seconds of integration per simulated
    second and the step [s] the TS took, of each configuration of ``variants`` run over
    ``end`` [s] from its preloaded equilibrium with a 1 nm seed, the variants alternated
    ``rounds`` times (one run each is too noisy on a shared machine: 10-30 % run to run)."""
    runs = {}
    for name, cfg in variants.items():
        start = cfg.replace(**{"time.start": "preload", "time.perturbation": 1e-9,
                               "time.end": end, "time.window": end})
        problem = WheelProblem(model, start, [force_parameters(model, start, None)],
                               petsc().COMM_SELF)
        try:
            u0 = initial_state(problem)[0][: 2 * model.size]
        finally:
            problem.destroy()
        runs[name] = (start, u0)
    cost = {name: [] for name in variants}
    steps = {}
    for _ in range(rounds):
        for name, (start, u0) in runs.items():
            res = run_case(model, start, u0=u0)
            if res.status != "done":
                raise RuntimeError(f"bench: the {name} run {res.status}")
            cost[name].append(res.wall_s / end)
            steps[name] = float(res.options["ts_dt"])
    return {name: [min(c), float(np.median(c))] for name, c in cost.items()}, steps
