"""Linear stability over the case grid (``wheelrom stability``): every case of the sweep's
contact angles analysed at its preloaded equilibrium (:mod:`wheelrom.analysis.stability`),
cases dealt round-robin to the MPI ranks and gathered on rank 0, written by rank 0 (a
stability file is small: no parallel HDF5 needed).

The model is built once on rank 0 and broadcast, as in the transient sweep, so the results do
not depend on the number of ranks.
"""

from __future__ import annotations

import os
import time

import numpy as np

from wheelrom.analysis.margin import case_margin
from wheelrom.analysis.stability import StabilityResult, analyse
from wheelrom.config import Config
from wheelrom.results import layout as results
from wheelrom.rom.build import build_model
from wheelrom.runtime.errors import InputError


def run_stability(cfg: Config, comm=None, log=print,
                  margin: bool = False) -> tuple[object, list[StabilityResult]]:
    """``(model, results)`` of every case of ``cfg``'s grid, in case order, on rank 0 of the
    mpi4py ``comm`` (``None``: serial); other ranks get ``(model, [])``. ``margin``: also the
    flutter margin of every case (:mod:`wheelrom.analysis.margin`)."""
    from wheelrom.runtime.environment import petsc, slepc

    refuse_study(cfg, "stability")
    # PetscInitialize is collective on COMM_WORLD: every rank, before rank 0 builds alone
    petsc()
    slepc()
    rank, size = (comm.rank, comm.size) if comm is not None else (0, 1)
    say = log if rank == 0 else (lambda *_: None)
    t0 = time.perf_counter()
    model = build_model(cfg, petsc().COMM_SELF, log=say) if rank == 0 else None
    if comm is not None:
        model = comm.bcast(model)
    say(f"model ready in {time.perf_counter() - t0:.1f} s: {model.blades} blades x "
        f"{model.modes} modes")
    if margin and not model.tuned:  # every rank has the model: all refuse together
        raise InputError("--margin: the flutter margin needs a tuned wheel (it scans mu over "
                         "the ND blocks); [mistuning] is set, so 'stability' without --margin "
                         "gives the mistuned growth rates")
    angles = results.case_angles(cfg)
    mine = []
    for i in range(rank, angles.shape[0], size):
        try:
            res = _analyse(model, cfg, results.angles_of(angles[i]), margin)
        except Exception as exc:  # one case's failure (e.g. its equilibrium) is reported,
            res = f"{type(exc).__name__}: {exc}"  # never a hang of the other ranks
        mine.append((i, res))
        if rank == 0:
            said = res if isinstance(res, str) else (
                f"{res.verdict()}, {res.describe()}{_margin_text(res)} ({res.wall_s:.2f} s)")
            say(f"[case {i}/{angles.shape[0] - 1}] {_case_label(angles[i])}: {said}")
    gathered = comm.gather(mine, root=0) if comm is not None else [mine]
    ordered = []
    if rank == 0:
        ordered = sorted((item for part in gathered for item in part), key=lambda it: it[0])
    failed = [(i, why) for i, why in ordered if isinstance(why, str)]
    failed = comm.bcast(failed) if comm is not None else failed  # every rank stops together
    if failed:
        listing = "; ".join(f"case {i} ({_case_label(angles[i])}): {why}" for i, why in failed)
        raise InputError(f"linear stability failed for {len(failed)} case(s): {listing}"[:2000])
    return model, [res for _, res in ordered]


def refuse_study(cfg: Config, command: str) -> None:
    """A configuration with a ``[study]`` (grid, zip or cases) is run by ``wheelrom study``:
    ``sweep`` and ``stability`` would silently run the ``[sweep]`` angles instead."""
    st = cfg.study
    if st.grid or st.zip or st.cases:
        raise InputError(f"{cfg.source}: has a [study] section, which '{command}' does not run "
                         "(it runs the [sweep] angles): use 'wheelrom study'")


def _analyse(model, cfg: Config, angles_deg: dict, margin: bool) -> StabilityResult:
    """One case's stability, with its flutter margin when asked (wall time included)."""
    if not margin:
        return analyse(model, cfg, angles_deg)
    t0 = time.perf_counter()
    res = analyse(model, cfg, angles_deg, keep_jacobian=True)
    res.flutter_margin = case_margin(model, cfg, res)
    res.jacobian = None
    res.wall_s = time.perf_counter() - t0
    return res


def _margin_text(res: StabilityResult) -> str:
    m = res.flutter_margin
    if m is None:
        return ""
    if m.critical_mu == 0:
        return "; unstable without self-excitation"
    if not np.isfinite(m.critical_mu):
        return "; margin: stable for every scanned " + ("factor" if m.table else "mu")
    above = (f"{m.critical_mu:.4g} x the aerodynamic table" if m.table else
             f"mu = {m.critical_mu:.4g} N s/m")
    return (f"; margin: unstable above {above} ({m.ratio:.3g} x), "
            f"ND {m.nodal_diameter} at {m.frequency_hz:.4g} Hz")


def attach_linear(model, cfg: Config, angles_deg: dict, result) -> None:
    """Add the case's linear stability and the classification from both analyses to a
    transient :class:`~wheelrom.transient.problem.CaseResult` (a failed analysis leaves
    ``linear`` None and says so; it never fails the case)."""
    try:
        res = analyse(model, cfg, angles_deg)
    except Exception as exc:  # e.g. an equilibrium SNES that does not converge
        result.classification = f"unknown (linear analysis failed: {exc})"[:200]
        return
    i = res.critical()
    attach_classification(result, float(res.growth_rate[i]), int(res.nodal_diameter[i]),
                          float(res.frequency_hz[i]))


def attach_classification(result, growth_rate: float, nodal_diameter: int,
                          frequency_hz: float) -> None:
    """Add the case's fastest linear mode (growth rate [1/s], ND, frequency [Hz]: already
    analysed, e.g. a study's ``/stability``) and the classification from both analyses to a
    transient :class:`~wheelrom.transient.problem.CaseResult`."""
    from wheelrom.analysis.stability import classify

    result.linear = {"growth_rate": growth_rate, "nodal_diameter": nodal_diameter,
                     "frequency_hz": frequency_hz}
    if not result.status.startswith("done") or result.window_end.size == 0:
        result.classification = f"linear growth {growth_rate:+.3g} /s; transient failed"
        return
    # compare like with like: the travelling-wave components, not ND 0 where the static
    # preload deflection sits (unless the linear analysis says ND 0 is the one that grows)
    _, per_nd = result.growth_rates()
    first = 0 if nodal_diameter == 0 else 1
    transient_rate = float(np.nanmax(per_nd[first:])) if np.isfinite(per_nd[first:]).any() else (
        float("nan"))
    vibration = float(np.nanmax(result.nd_spectrum[-1][first:]))  # [m], last window
    last_open = {k: float(v[-1]) for k, v in result.open_fraction.items() if v.size}
    result.classification = classify(growth_rate, transient_rate, vibration,
                                     last_open)


def _case_label(row) -> str:
    return f"tie-boss {row[0]:g} deg, shroud {row[1]:g} deg"


def world_if_parallel():
    """mpi4py's COMM_WORLD under mpirun with more than one rank, else None (serial)."""
    if int(os.environ.get("OMPI_COMM_WORLD_SIZE", os.environ.get("PMI_SIZE", "1"))) <= 1:
        return None
    from mpi4py import MPI

    return MPI.COMM_WORLD


def summary(res: StabilityResult) -> dict:
    """The case's verdict and fastest mode as plain data (``stability --json``)."""
    i = res.critical()
    return {
        "angles_deg": res.angles_deg,
        "verdict": res.verdict(),
        "max_growth_rate": float(res.growth_rate[i]),
        "nodal_diameter": int(res.nodal_diameter[i]),
        "frequency_hz": float(res.frequency_hz[i]),
        "damping_ratio": float(res.damping_ratio[i]),
        "mode": res.describe(i),
        "contact_gap_per_tip": {kind: {"normal": float(res.contact_normal[i, c]),
                                       "tangential": float(res.contact_tangential[i, c])}
                                for c, kind in enumerate(res.kinds)},
        "min_normal_force_n": {k: float(res.normal_force[c].min())
                               for c, k in enumerate(res.kinds)},
        "min_margin_m": {k: float(res.margin[c].min()) for c, k in enumerate(res.kinds)},
        "unstable_nodal_diameters": sorted({int(k) for k, g in
                                            zip(res.nodal_diameter, res.growth_rate, strict=True)
                                            if g > 1e-6}),
        "wall_s": res.wall_s,
    } | _margin_summary(res.flutter_margin)


def _margin_summary(m) -> dict:
    if m is None:
        return {}
    return {"flutter_margin": {
        "critical_mu": _finite_or_none(m.critical_mu), "ratio": _finite_or_none(m.ratio),
        "nodal_diameter": m.nodal_diameter, "frequency_hz": _finite_or_none(m.frequency_hz),
        "growth_rate_without_self_excitation": m.growth_at_zero,
        "scaled": "aerodynamic table" if m.table else "van der pol mu"}}


def _finite_or_none(x: float):
    """JSON has no inf: ``None`` for "no crossing in the scanned range"."""
    return float(x) if np.isfinite(x) else None
