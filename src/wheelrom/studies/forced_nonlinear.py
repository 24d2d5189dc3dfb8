"""The nonlinear forced response of one case (``wheelrom forced-response --nonlinear``, and
per case of ``wheelrom study --forced-nonlinear``, the friction damper's design curve; issue
#45): the preloaded equilibrium (nozzle off) and the harmonic balance of the nozzle's
travelling wave under the configured contact law
(:mod:`wheelrom.analysis.periodic.forced_wave`), over a band that holds the resonance
whether the contacts stick or slip."""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from wheelrom.analysis.forced import operators, speed_following
from wheelrom.analysis.forced_peak import resonance
from wheelrom.analysis.periodic.forced_branch import traced_curve
from wheelrom.analysis.periodic.forced_perturbed import settle_unstable
from wheelrom.analysis.periodic.forced_segments import segment_count, segmented_curve
from wheelrom.analysis.periodic.forced_shooting import ForcedOrbit, exact_forced
from wheelrom.analysis.periodic.forced_wave import ForcedCurve, ForcedWave, forced_curve
from wheelrom.analysis.stability import linearise
from wheelrom.config import Config
from wheelrom.forces.parameters import force_parameters
from wheelrom.results import layout as results
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime.errors import InputError
from wheelrom.studies.queue import CaseQueue

#: the automatic band's margin beyond the slipping and the stuck resonance (a share of each)
BAND_MARGIN = 0.03


def nonlinear_forced(model: ReducedModel, cfg: Config, frequencies: np.ndarray,
                     angles_deg: dict | None = None, harmonics: int = 5, comm=None,
                     progress=None, refine: bool = False, inputs: tuple | None = None,
                     ranks=None) -> ForcedCurve:
    """The steady response at every excitation frequency of ``frequencies`` [rad/s] (in
    that order) of the tuned ``model`` under ``cfg`` (its contact law, the Van der Pol force
    as configured), contact angles ``angles_deg`` as :func:`linearise`; ``refine``: also the
    peak off the grid; ``inputs``: the case's :func:`forced_inputs` when already known;
    ``ranks``: an mpi4py communicator whose ranks share the frequencies in segments
    (:mod:`~wheelrom.analysis.periodic.forced_segments`; every rank gets the whole curve)."""
    params, q = inputs or forced_inputs(model, cfg, angles_deg, comm)
    if ranks is not None and ranks.size > 1:  # segments taken as ranks become free
        count = segment_count(np.size(frequencies), ranks.size)
        queue = CaseQueue(count, ranks)
        curve = segmented_curve(model, params, cfg.wheel.damping_beta, frequencies, q, ranks,
                                harmonics=harmonics, progress=progress, refine=refine,
                                segments=count, taken=queue)
        queue.free()  # every rank met again in the segments' gather (a failure aborts the job)
        return curve
    return forced_curve(model, params, cfg.wheel.damping_beta, frequencies, q,
                        harmonics=harmonics, progress=progress, refine=refine)


def nonlinear_inputs_problem(cfg: Config, points: int | None = None) -> str | None:
    """Why the nonlinear forced response of ``cfg`` cannot be computed, known from its keys
    before any model is built (None: it can): no nozzle force, a mistuned wheel (the balance
    is of one travelling wave), or no grid frequency to solve at (``points``: the coarse
    grid's count of ``forced-response``; None: a study case's, at least 3 whatever
    ``forced.points``). The command and every case of a study ask it up front, so that no
    case fails for it after others were computed."""
    from wheelrom.rom.model import blade_mistuning

    if cfg.excitation.force <= 0:
        return "excitation.force = 0: the nozzle force is off, nothing is forced"
    if blade_mistuning(cfg) is not None:
        return ("the travelling-wave harmonic balance needs a tuned wheel; [mistuning] is set "
                "(mistuning.pattern, file, alternate or std)")
    if points == 0:
        return ("forced.points = 0 leaves no grid frequency to solve the nonlinear response "
                "at: set forced.points >= 1 or give --frequencies A:B:N")
    return None


def check_nonlinear_memory(cfg: Config, harmonics: int, frequencies: int, given: str) -> None:
    """Refuse, before any model is built, a nonlinear forced response of ``harmonics`` H over
    ``frequencies`` F grid points that does not fit in the memory (``given``: the options or
    keys that set H and F, as the user gave them). Its peak: the balance's projectors
    ``2 (2H + 1)^2 3 n_t`` (``n_t = 8 (H + 1)`` samples), three dense Jacobians of ``n =
    (2H + 1) m`` unknowns, and the curve's harmonics ``3 F (2H + 1) m`` doubles (``m``: the
    basis vectors, :func:`~wheelrom.rom.bases.basis_size`)."""
    from wheelrom.rom.bases import basis_size
    from wheelrom.runtime.outputs import check_memory

    rows, samples = 2 * harmonics + 1, 8 * (harmonics + 1)
    unknowns = rows * basis_size(cfg)
    needed = 8 * (2 * rows**2 * 3 * samples + 3 * unknowns**2 + 3 * frequencies * unknowns)
    check_memory(needed, given, "fewer harmonics or frequencies")


def forced_inputs(model: ReducedModel, cfg: Config, angles_deg: dict | None = None,
                  comm=None) -> tuple:
    """``(force parameters, preloaded equilibrium (N, m))`` of a nonlinear forced case (the
    equilibrium with the nozzle off), after the checks of its configuration."""
    if not model.tuned:
        raise InputError("forced-response --nonlinear: the travelling-wave harmonic balance "
                         "needs a tuned wheel; [mistuning] is set")
    if cfg.excitation.force <= 0:
        raise InputError("forced-response --nonlinear: excitation.force = 0: the nozzle "
                         "force is off, nothing is forced")
    _, q, _, _, _ = linearise(model, cfg, angles_deg, comm)
    return force_parameters(model, cfg, angles_deg), q


def nonlinear_band(model: ReducedModel, cfg: Config, angles_deg: dict | None = None,
                   comm=None) -> tuple[tuple[float, float], list[float]]:
    """``((lo, hi), resonances)`` [rad/s]: the band, ``forced.band_hz`` when given, else from
    the resonance of ``forced.family`` at the excited ND with the contacts slipping (their
    normal springs at the preloaded equilibrium, no tangential stiffness: the paper law's
    linearisation without its friction damping) to the one with them stuck (the elastic
    law's tangential springs ``k_t``), widened by :data:`BAND_MARGIN`; ``resonances``: those
    two frequencies (one under the paper law, where they coincide), which the grid of
    :func:`design_point` holds whatever its spacing (the stuck one is lightly damped and
    sharp). Friction holds the resonance between the two (docs/theory.md, "The friction
    damper's design curve")."""
    # the paper law's linearisation: its stiffness is the normal springs' alone (its friction
    # is a damper there); replaced as data, the elastic keys are not validated again
    slipping = dataclasses.replace(cfg, contacts=dataclasses.replace(cfg.contacts, law="paper"))
    found = []
    for case in [slipping] + ([cfg] if cfg.contacts.elastic else []):
        J = linearise(model, case, angles_deg, comm)[3]
        K, _ = operators(model, case, True, angles_deg, comm, jacobian=J)
        found.append(resonance(K, model, cfg.wheel.stator_vanes, cfg.forced.family,
                               speed_following(model, cfg)))
    if cfg.forced.band_hz:
        lo, hi = (2 * math.pi * f for f in cfg.forced.band_hz)
        return (lo, hi), [w for w in found if lo <= w <= hi]
    return ((1.0 - BAND_MARGIN) * min(found), (1.0 + BAND_MARGIN) * max(found)), found


@dataclasses.dataclass
class DesignPoint:
    """One case of the design study: its curve over ``band`` [rad/s] (refined peak in
    ``curve.refined``) and the wall time [s]."""

    curve: ForcedCurve
    band: tuple[float, float]
    wall_s: float
    #: ``forced.exact``: the refined peak's exact state (:func:`exact_summary`), else None
    exact: dict | None = None


def design_point(model: ReducedModel, cfg: Config, angles_deg: dict | None = None,
                 comm=None) -> DesignPoint:
    """The nonlinear forced response of one study case over :func:`nonlinear_band` on
    ``forced.points`` frequencies (at least 3) and the band's linear resonances,
    ``forced.harmonics`` harmonics, with its peak refined."""
    t0 = time.perf_counter()
    band, resonances = nonlinear_band(model, cfg, angles_deg, comm)
    grid = np.unique(np.concatenate([np.linspace(*band, max(cfg.forced.points, 3)),
                                     resonances]))
    inputs = forced_inputs(model, cfg, angles_deg, comm)  # one equilibrium for both
    curve = nonlinear_forced(model, cfg, grid, angles_deg, cfg.forced.harmonics, comm,
                             refine=True, inputs=inputs)
    if cfg.forced.continuation == "arclength":
        curve = trace_after_grid(model, cfg, curve, band, inputs)
    exact = None
    if cfg.forced.exact and curve.refined is not None:
        r = curve.refined
        exact = exact_summary(exact_peak(model, cfg, r.harmonics, r.frequency,
                                         (curve.harmonics.shape[1] - 1) // 2, inputs,
                                         angles_deg, whole_wheel=True))
    return DesignPoint(curve, band, time.perf_counter() - t0, exact)


def exact_peak(model: ReducedModel, cfg: Config, X: np.ndarray, omega: float,
               harmonics: int, inputs: tuple, angles_deg: dict | None = None,
               whole_wheel: bool = False, settle: bool = False) -> ForcedOrbit:
    """The exact state by shooting from the balance's state ``X`` ``(2H + 1, m)`` at
    ``omega`` [rad/s] (``inputs``: the case's :func:`forced_inputs`; ``whole_wheel``: its
    multipliers in every ND too; ``settle``: where the wheel goes when it is unstable,
    :func:`~wheelrom.analysis.periodic.forced_perturbed.settle_unstable`)."""
    problem = ForcedWave(model, inputs[0], cfg.wheel.damping_beta, harmonics)
    orbit = exact_forced(model, cfg, problem, X, omega, angles_deg, whole_wheel=whole_wheel)
    if settle:
        settle_unstable(model, cfg, problem, orbit, angles_deg)
    return orbit


def exact_summary(orbit: ForcedOrbit) -> dict:
    """Plain numbers of an exact state: ``converged``, ``tip_amplitude`` [m] (NaN when not
    converged), ``largest`` ``|mu|`` and ``coarse_largest`` (at twice the step), the
    dominant multiplier's ``nodal_diameter`` (-1: none), ``residual``; in every ND
    ``wheel_largest`` and ``wheel_nodal_diameter`` (NaN / -1: not computed)."""
    done = orbit.converged
    every = done and orbit.wheel_multipliers.size > 0
    return {"converged": bool(done), "residual": float(orbit.residual),
            "tip_amplitude": float(orbit.tip_amplitude) if done else math.nan,
            "largest": float(orbit.largest) if done else math.nan,
            "coarse_largest": float(orbit.coarse_largest) if done else math.nan,
            "nodal_diameter": int(orbit.nodal_diameters[0]) if done and
            orbit.nodal_diameters.size else -1,
            "wheel_largest": float(abs(orbit.wheel_multipliers[0])) if every else math.nan,
            "wheel_nodal_diameter": int(orbit.wheel_nodal_diameters[0]) if every else -1}


def trace_after_grid(model: ReducedModel, cfg: Config, grid: ForcedCurve, band: tuple,
                     inputs: tuple) -> ForcedCurve:
    """The curve over ``band`` [rad/s] traced by arclength continuation
    (:func:`~wheelrom.analysis.periodic.forced_branch.traced_curve`), its unit of the
    harmonics the largest of the ``grid`` solve; its peak the larger of the two refined
    ones (a curve of contacts that stick and slip is wavy at low H: either search may find
    the larger local maximum); each point's stability by Hill's method under the paper law
    (``curve.growth``); the grid's harmonics and wall time included; ``inputs``: the case's
    :func:`forced_inputs` (the grid's)."""
    params, q = inputs
    solved = grid.harmonics[grid.converged, 1:]
    x_ref = float(np.abs(solved).max()) if solved.size else 0.0
    spacing = np.diff(np.sort(grid.frequency))
    jump = float(spacing.max()) if spacing.size else band[1] - band[0]  # the grid's spacing
    curve = traced_curve(model, params, cfg.wheel.damping_beta, band, q,
                         harmonics=(grid.harmonics.shape[1] - 1) // 2, x_ref=x_ref, refine=True,
                         jump=jump, stability=True)
    if grid.refined is not None and (curve.refined is None or grid.refined.tip_amplitude
                                      > curve.refined.tip_amplitude):
        curve.refined = grid.refined
    curve.wall_s += grid.wall_s
    return curve


def design_arrays(found: list) -> dict[str, np.ndarray]:
    """``/forced_nonlinear`` datasets (docs/output.md) from one :func:`design_point` or the
    text of its failure per case (case order); ``kinds``: the contact kinds of
    ``peak_fractions`` (a study case's kinds are every case's)."""
    kinds = next((p.curve.kinds for p in found if not isinstance(p, str)), ())
    C, K = len(found), len(kinds)
    F = max((p.curve.frequency.size for p in found if not isinstance(p, str)), default=0)
    out = {name: np.full(shape, np.nan) for name, shape in (
        ("frequency_hz", (C, F)), ("tip_amplitude", (C, F)), ("band_hz", (C, 2)),
        ("growth", (C, F)),
        ("peak_amplitude", (C,)), ("peak_frequency_hz", (C,)), ("peak_fractions", (C, K, 3)),
        ("grid_peak_amplitude", (C,)), ("wall_s", (C,)),
        ("exact_tip_amplitude", (C,)), ("exact_largest_multiplier", (C,)),
        ("exact_largest_multiplier_at_twice_the_step", (C,)),
        ("exact_wheel_largest_multiplier", (C,)),
        ("folds_hz", (C, max((p.curve.folds.size for p in found if not isinstance(p, str)),
                             default=0))))}
    out["converged"] = np.zeros((C, F), dtype=bool)
    out["nodal_diameter"] = np.full(C, -1, dtype="i8")
    out["exact_multiplier_nd"] = np.full(C, -1, dtype="i8")
    out["exact_wheel_multiplier_nd"] = np.full(C, -1, dtype="i8")
    status = []
    for c, point in enumerate(found):
        if isinstance(point, str):
            status.append(f"failed: {point}"[: results.STATUS_LEN])
            continue
        curve, n = point.curve, point.curve.frequency.size
        out["frequency_hz"][c, :n] = curve.frequency / (2 * math.pi)
        out["tip_amplitude"][c, :n] = curve.tip_amplitude
        out["converged"][c, :n] = curve.converged
        if curve.growth.size:
            out["growth"][c, :n] = curve.growth
        out["band_hz"][c] = np.asarray(point.band) / (2 * math.pi)
        out["nodal_diameter"][c] = curve.nodal_diameter
        out["wall_s"][c] = point.wall_s
        if curve.refined is None:
            status.append("failed: no frequency of the band converged")
            continue
        out["grid_peak_amplitude"][c] = curve.tip_amplitude[curve.peak]
        out["peak_amplitude"][c] = curve.refined.tip_amplitude
        out["peak_frequency_hz"][c] = curve.refined.frequency / (2 * math.pi)
        out["peak_fractions"][c] = curve.refined.fractions
        out["folds_hz"][c, : curve.folds.size] = curve.folds / (2 * math.pi)
        if point.exact is not None:  # forced.exact
            e = point.exact
            out["exact_tip_amplitude"][c] = e["tip_amplitude"]
            out["exact_largest_multiplier"][c] = e["largest"]
            out["exact_largest_multiplier_at_twice_the_step"][c] = e["coarse_largest"]
            out["exact_multiplier_nd"][c] = e["nodal_diameter"]
            out["exact_wheel_largest_multiplier"][c] = e.get("wheel_largest", math.nan)
            out["exact_wheel_multiplier_nd"][c] = e.get("wheel_nodal_diameter", -1)
        if curve.trace:  # traced by arclength
            status.append(f"done (traced: {int(curve.converged.sum())} points, "
                          f"{curve.folds.size} folds; {curve.trace})")
        else:
            status.append(f"done ({int(curve.converged.sum())} of {n} frequencies converged)")
    out["status"] = np.array([s.encode() for s in status], dtype=f"S{results.STATUS_LEN}")
    out["kinds"] = np.array([k.encode() for k in kinds], dtype="S16")
    return out
