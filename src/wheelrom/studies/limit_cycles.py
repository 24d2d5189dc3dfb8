"""Limit cycles over the cases (``wheelrom limit-cycle``): every case of the ``[study]``
(any keys: a grid, zipped lists or CSV cases, so a sweep of a preload, a friction coefficient
or an angle gives the limit-cycle amplitude against it) or of the sweep's contact angles,
every travelling wave unstable at its preloaded equilibrium (or the waves asked for): the
harmonic balance and its continuation, the exact orbit by shooting
(:mod:`wheelrom.analysis.periodic.limit_cycle`); cases handed to the MPI ranks as they become
free (:mod:`.queue`) and gathered on rank 0, which writes the file.

The models (one per group of cases that share one) are built on rank 0 and broadcast, so the
results do not depend on the number of ranks (test: ``mpirun -n 2`` against one process).
"""

from __future__ import annotations

import time

import numpy as np

from wheelrom.analysis.periodic.limit_cycle import CaseLimitCycles, case_limit_cycles, settings_of
from wheelrom.config import Config
from wheelrom.config.study import expand, short_name
from wheelrom.runtime.errors import InputError
from wheelrom.studies.plan import shared_models
from wheelrom.studies.queue import CaseQueue


def run_limit_cycles(cfg: Config, comm=None, log=print, waves=None,
                     progress=None) -> tuple[object, list[CaseLimitCycles]]:
    """``(model, results)`` of every case of ``cfg``'s study (``[study]`` grid, zip or CSV
    cases of any keys, else the ``[sweep]`` angles) in case order on rank 0 of the mpi4py
    ``comm`` (``None``: serial); other ranks get ``(model, [])`` (``model``: the first
    case's). ``waves``: the travelling waves to analyse instead of ``limit_cycle.waves``;
    ``progress(text)`` (rank 0) at every branch point."""
    study = expand(cfg)
    rank = comm.rank if comm is not None else 0
    say = log if rank == 0 and log is not None else (lambda *_: None)
    t0 = time.perf_counter()
    model_of, models = shared_models(study.configs, comm, say)
    if not all(m.tuned for m in models):
        raise InputError("limit-cycle: the travelling-wave harmonic balance needs a tuned "
                         "wheel; [mistuning] is set")
    say(f"{len(models)} model(s) ready in {time.perf_counter() - t0:.1f} s: "
        f"{models[0].blades} blades x {models[0].modes} modes")
    mine, refused_input = [], set()  # the reasons of cases refused as bad input ("": other)
    queue = CaseQueue(study.size, comm)
    for i in queue:
        case_cfg = study.configs[i]
        label = f"[case {i}/{study.size - 1}] " + ", ".join(
            f"{short_name(k)} {v:g}" if isinstance(v, float) else f"{short_name(k)} {v}"
            for k, v in zip(study.names, study.values[i], strict=True))

        def point(wave, lam, amplitude, label=label):
            progress(f"{label}: wave {wave}, mu x {lam:.4g}, tip {amplitude * 1e6:.4g} um")

        try:
            res = case_limit_cycles(models[model_of[i]], case_cfg, settings_of(case_cfg, waves),
                                    progress=point if progress and rank == 0 else None)
        except Exception as exc:  # one case's failure is kept and named, the others go on
            angles = {k: case_cfg.contact(k).angle_deg for k in case_cfg.contacts.enabled_kinds()}
            why = str(exc) if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
            res = CaseLimitCycles(angles, (), None, [], 0.0, failure=why)
            refused_input.add(why if isinstance(exc, InputError) else "")
        res.parameters = dict(zip(study.names, study.values[i], strict=True))
        mine.append((i, res))
        if rank == 0:
            say(f"{label}: {res.verdict()} ({res.wall_s:.1f} s)")
    gathered = comm.gather(mine, root=0) if comm is not None else [mine]
    queue.free()
    ordered = []
    if rank == 0:
        ordered = sorted((item for part in gathered for item in part), key=lambda it: it[0])
    # every case refused as bad input for the same reason (no self-excitation): exit 2,
    # nothing to write; otherwise the failed cases are written with their reasons (exit 1)
    parts = comm.gather(refused_input, root=0) if comm is not None else [refused_input]
    refused = None
    if rank == 0:
        reasons = set().union(*parts)
        every = all(res.failure for _, res in ordered)
        refused = next(iter(reasons)) if every and len(reasons) == 1 and "" not in reasons \
            else None
    refused = comm.bcast(refused) if comm is not None else refused
    if refused:
        raise InputError(f"limit cycles: {refused}")
    return models[0], [res for _, res in ordered]



def summary(case: CaseLimitCycles) -> dict:
    """One case's limit cycles as plain data (``limit-cycle --json``)."""
    waves = []
    for b in case.branches:
        waves.append({
            "wave": b.wave, "nodal_diameter": b.nodal_diameter, "direction": b.direction,
            "critical_mu_factor": _finite_or_none(b.critical_lam),
            "hopf_hz": _finite_or_none(b.hopf_hz), "verdict": b.verdict(),
            "branch_points": len(b.points), "branch_end": b.end, "folds": len(b.folds),
            "cycles": [_cycle(c, case.kinds) for c in b.cycles], "wall_s": b.wall_s,
        })
    fastest = None if case.fastest is None else dict(
        zip(("wave", "nodal_diameter", "growth_rate"), case.fastest, strict=True))
    return {"angles_deg": case.angles_deg, "verdict": case.verdict(), "waves": waves,
            "fastest_wave": fastest, "wall_s": case.wall_s}


def _cycle(c, kinds) -> dict:
    out = {
        "mu_factor": c.lam, "frequency_hz": c.frequency_hz, "tip_amplitude_m": c.tip_amplitude,
        "tip_harmonics_m": [float(a) for a in c.tip_harmonics],
        "energy_per_cycle_j": {"self_excitation": c.energy_in,
                               "damping": c.energy_damping,
                               **{f"friction_{k}": float(e)
                                  for k, e in zip(kinds, c.energy_friction, strict=True)}},
        "energy_residual": c.energy_residual, "energy_residual_fine": c.energy_residual_fine,
        "damping_ratio": c.damping_ratio,
        "contacts": {k: {"normal_force_min_n": float(c.normal_force_range[i, 0]),
                         "normal_force_max_n": float(c.normal_force_range[i, 1]),
                         "open": float(c.fractions[i, 0]), "micro_slip": float(c.fractions[i, 1]),
                         "slip": float(c.fractions[i, 2])} for i, k in enumerate(kinds)},
        "stable": c.stable, "method": c.method,
    }
    out["source"] = c.source
    if c.shot_missed:
        out["shooting"] = {"converged": False, "residual": c.shooting_residual}
    if c.method == "shooting":
        out["shooting"] = {"converged": True, "residual": c.shooting_residual,
                           "hb_tip_amplitude_m": c.hb_tip_amplitude,
                           "hb_frequency_hz": c.hb_frequency_hz,
                           "hb_amplitude_difference": c.hb_tip_amplitude / c.tip_amplitude - 1,
                           "hb_frequency_difference": c.hb_frequency_hz / c.frequency_hz - 1}
    if c.multipliers is not None:
        mu = c.multipliers
        out["multipliers"] = [{"modulus": float(abs(v)), "phase_rad": float(np.angle(v)),
                               "nd": int(nd), "wave": int(k)}
                              for v, nd, k in zip(mu.values, mu.nd, mu.wave, strict=True)]
    if c.refined:  # the in-symmetry multiplier's steps (also without the whole wheel's)
        out["refined_multiplier"] = [{"step_s": s, "modulus": v, "nd": nd}
                                     for s, v, nd in c.refined]
    if c.stability is not None:
        out["floquet"] = {"largest_multiplier": c.stability.multiplier,
                          "trivial_multiplier_error": c.stability.trivial,
                          "trusted": c.stability.trusted,
                          "worst_family": c.stability.worst_family}
    if c.band is not None:
        out["band"] = band_summary(c.band)
    return out


def band_summary(band) -> dict:
    """The elastic law's friction-limited band (:class:`~wheelrom.analysis.periodic.family.
    Band`) as plain data: tip amplitudes [m], offsets [stick radii], radii [m]."""
    return {"low_m": band.low.tip, "high_m": band.high.tip, "orbit_m": band.start_tip,
            "stuck_kinds": list(band.kinds), "stick_radius_m": [float(r) for r in band.radius],
            "low_offset": [float(x) for x in band.low.offset],
            "high_offset": [float(x) for x in band.high.offset],
            "low_multiplier": _finite_or_none(band.multiplier_low),
            "high_multiplier": _finite_or_none(band.multiplier_high),
            "members": len(band.members), "traces": band.reason}


def _finite_or_none(x: float):
    return float(x) if np.isfinite(x) else None
