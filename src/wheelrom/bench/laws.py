"""``bench``'s cost of the elastic Coulomb contact against the paper's law (issue #44: an
elastic-law transient at most 1.5x the paper law's per simulated second), one core:

- ``law_s_per_simulated_s``: ``{"paper": [min, median], "elastic": [min, median]}`` seconds
  of integration per simulated second of the configured case (its scheme and step; each law
  takes the step its TS takes, the elastic law's lowered to its stable step), 20.16 ms from
  each law's preloaded equilibrium with a 1 nm seed, the two laws alternated ``ROUNDS`` times
  (one run each is too noisy on a shared machine: 10-30 % run to run);
- ``elastic_vs_paper``: ``[min, median]`` the elastic law's over the paper law's;
- ``law_steps_s``: each law's step [s].
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


def law_figures(model: ReducedModel, cfg: Config, say, rounds: int = ROUNDS,
                end: float = END) -> dict:
    """The figures above (``say``: progress lines; ``rounds`` alternations of runs over
    ``end`` [s] of simulated time)."""
    runs = {}
    for law in LAWS:
        start = cfg.replace(**{"contacts.law": law, "time.start": "preload",
                               "time.perturbation": 1e-9, "time.end": end,
                               "time.window": end})
        problem = WheelProblem(model, start, [force_parameters(model, start, None)],
                               petsc().COMM_SELF)
        try:
            u0 = initial_state(problem)[0][: 2 * model.size]
        finally:
            problem.destroy()
        runs[law] = (start, u0)
    cost = {law: [] for law in LAWS}
    steps = {}
    for _ in range(rounds):
        for law in LAWS:
            start, u0 = runs[law]
            res = run_case(model, start, u0=u0)
            if res.status != "done":
                raise RuntimeError(f"bench: the {law} law's run {res.status}")
            cost[law].append(res.wall_s / end)
            steps[law] = float(res.options["ts_dt"])
    figures = {law: [min(c), float(np.median(c))] for law, c in cost.items()}
    ratio = [figures["elastic"][0] / figures["paper"][0],
             figures["elastic"][1] / figures["paper"][1]]
    say(f"laws: paper {figures['paper'][0]:.2f} / {figures['paper'][1]:.2f}, elastic "
        f"{figures['elastic'][0]:.2f} / {figures['elastic'][1]:.2f} s per simulated s (min / "
        f"median of {rounds}): {ratio[0]:.2f}x / {ratio[1]:.2f}x")
    return {"law_s_per_simulated_s": figures, "elastic_vs_paper": ratio,
            "law_steps_s": steps}
