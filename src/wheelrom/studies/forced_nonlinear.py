"""The nonlinear forced response of one case over a frequency grid (``wheelrom
forced-response --nonlinear``; issue #45, first part): the preloaded equilibrium (nozzle off)
and the harmonic balance of the nozzle's travelling wave under the configured contact law
(:mod:`wheelrom.analysis.periodic.forced_wave`)."""

from __future__ import annotations

import numpy as np

from wheelrom.analysis.periodic.forced_wave import ForcedCurve, forced_curve
from wheelrom.analysis.stability import linearise
from wheelrom.config import Config
from wheelrom.forces.parameters import force_parameters
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime.errors import InputError


def nonlinear_forced(model: ReducedModel, cfg: Config, frequencies: np.ndarray,
                     angles_deg: dict | None = None, harmonics: int = 5, comm=None,
                     progress=None) -> ForcedCurve:  # fmt: skip
    """The steady response at every excitation frequency of ``frequencies`` [rad/s] (in
    that order) of the tuned ``model`` under ``cfg`` (its contact law, the Van der Pol force
    as configured), contact angles ``angles_deg`` as :func:`linearise`."""
    if not model.tuned:
        raise InputError("forced-response --nonlinear: the travelling-wave harmonic balance "
                         "needs a tuned wheel; [mistuning] is set")  # fmt: skip
    if cfg.excitation.force <= 0:
        raise InputError("forced-response --nonlinear: excitation.force = 0: the nozzle "
                         "force is off, nothing is forced")  # fmt: skip
    _, q, _, _, _ = linearise(model, cfg, angles_deg, comm)  # the equilibrium, nozzle off
    params = force_parameters(model, cfg, angles_deg)
    return forced_curve(model, params, cfg.wheel.damping_beta, frequencies, q,
                        harmonics=harmonics, progress=progress)  # fmt: skip
