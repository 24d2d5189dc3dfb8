"""``wheelrom forced-response``: the steady response to the nozzle over a frequency (or speed)
range, of the configured wheel and the tuned one, with the amplification factor."""

from __future__ import annotations

import argparse
import math

import numpy as np

from wheelrom.cli.args import (
    comm_self,
    excitation_band,
    force,
    json_out,
    load_config,
    locked,
    parse_angles,
)
from wheelrom.cli.output import log, print_json
from wheelrom.config import with_option
from wheelrom.results.layout import FORCED_FORMAT as FORMAT
from wheelrom.runtime.errors import InputError
from wheelrom.runtime.outputs import agree, check_output, save_hdf5


def args_forced(p: argparse.ArgumentParser) -> None:
    p.add_argument("--frequencies", metavar="A:B:N",
                   help="excitation frequencies [Hz]: the band from A to B and a coarse grid "
                   "of N values in it, instead of forced.band_hz and forced.points")
    p.add_argument("--speeds", metavar="A:B:N",
                   help="rotor speeds [Hz] instead: the nozzle frequencies n_s A .. n_s B and a "
                   "grid of N speeds (the stiffness follows them with forced.over = 'speed', "
                   "else stays at wheel.speed_hz's)")
    p.add_argument("--contacts", action=argparse.BooleanOptionalAction, default=None,
                   help="linearise the contacts at the preloaded equilibrium or leave them out "
                   "(K_R and beta_D K_R only); default forced.contacts")
    p.add_argument("--nonlinear", action="store_true",
                   help="also the nonlinear steady response at every frequency of the grid: "
                   "harmonic balance of the nozzle's travelling wave under contacts.law "
                   "(tuned wheel; docs/theory.md 'Nonlinear forced response')")
    p.add_argument("--harmonics", type=int, default=None,
                   help="harmonics of --nonlinear (default forced.harmonics)")
    p.add_argument("--exact", nargs="?", const="peak", choices=("peak", "all", "none"),
                   default=None,
                   help="with --nonlinear: the exact periodic state at the nonlinear peak "
                   "('peak'; by default when forced.exact, 'none': the balance's peak "
                   "alone) or at every solved frequency ('all': the curve's "
                   "stable and unstable parts) by shooting on the transient's equations (the "
                   "harmonic balance's error) and its Floquet multipliers in every ND; an "
                   "unstable state is then perturbed and the whole wheel integrated from it "
                   "until bounded: where the wheel goes (docs/theory.md)")
    p.add_argument("--angle", nargs=2, action="append", default=[], metavar=("KIND", "DEG"),
                   help="contact angle [deg] of a kind (tieboss, shroud) instead of "
                   "contacts.<kind>.angle_deg (repeatable)")
    json_out(p)
    p.add_argument("--out", help="write the response to this HDF5 file")
    force(p)


@locked("--out")
def cmd_forced(args: argparse.Namespace) -> int:
    """Forced response to the nozzle at engine order wheel.stator_vanes. Linear: the peak of
    the largest blade tip amplitude over the band of [forced] (or --frequencies), refined
    independently of any grid, of the configured wheel and of the tuned wheel, and the
    amplification factor (peak over peak); the coarse grid's values as a table. With
    --nonlinear also the tuned wheel's steady response with friction at every grid frequency,
    by harmonic balance of the nozzle's travelling wave under contacts.law (traced through
    its folds by arclength with forced.continuation = 'arclength'); with --exact its exact
    state by shooting and the state's Floquet multipliers. PETSc prefixes forced_ (KSP) and
    forced_preload_ (SNES)."""
    from wheelrom.analysis.forced_peak import peak_response, tuned_reference
    from wheelrom.rom.bases import basis_size
    from wheelrom.rom.build import build_model, quiet
    from wheelrom.studies.forced_nonlinear import (
        check_nonlinear_memory,
        nonlinear_inputs_problem,
    )
    from wheelrom.studies.stability import world_if_parallel

    cfg = load_config(args)
    if args.harmonics is not None:  # forced.harmonics' range (at most 64), named as the option
        with_option(cfg, f"--harmonics {args.harmonics}", {"forced.harmonics": args.harmonics})
        if not args.nonlinear:
            raise InputError("--harmonics sets the nonlinear response's: give --nonlinear too")
    args.harmonics = cfg.forced.harmonics if args.harmonics is None else args.harmonics
    if args.exact not in (None, "none") and not args.nonlinear:
        raise InputError("--exact checks the nonlinear response: give --nonlinear too")
    if args.nonlinear and args.contacts is False:  # the balance is the contacts' nonlinearity
        raise InputError("--no-contacts leaves the contacts out of the linear response only; "
                         "the nonlinear one is theirs (leave a kind out with contacts.<kind>."
                         "enabled = false)")
    if cfg.excitation.force <= 0:  # a response of zero (and a peak search of nothing)
        raise InputError("excitation.force = 0: the nozzle force is off, nothing is forced")
    band, points = excitation_band(args, cfg)
    if args.nonlinear:
        nonlinear_problem = nonlinear_inputs_problem(
            cfg, cfg.forced.points if points is None else points)
        if nonlinear_problem:
            raise InputError(f"forced-response --nonlinear: {nonlinear_problem}")
        count = cfg.forced.points if points is None else points
        check_nonlinear_memory(cfg, args.harmonics, count, f"--nonlinear at H = "
                               f"{args.harmonics} over {count} frequencies of "
                               f"{basis_size(cfg)} basis vectors")
    contacts = cfg.forced.contacts if args.contacts is None else args.contacts
    angles = parse_angles(args.angle, cfg) or None
    if args.out:
        check_output(args.out, args.force)
    say = quiet if args.json else log
    model = build_model(cfg, comm_self(), log=say)
    if cfg.forced.over == "speed":
        say(_speed_note(model, cfg))
    band, resonances = _nonlinear_resonances(model, cfg, angles, band, say) \
        if args.nonlinear else (band, None)  # friction holds the nonlinear peak between them
    say("the tuned reference (mistuning removed)" if not model.tuned else "the tuned wheel")
    tuned = tuned_reference(model, cfg, [model.mistuning], contacts, angles, comm_self(),
                            band_hz=band, points=points)
    response = tuned
    if not model.tuned:
        say("the mistuned wheel")
        response = peak_response(model, cfg, tuned.band_hz, contacts, angles, comm_self(),
                                 points=points)
    out = summary(response, tuned, cfg, model, contacts)
    curve, world = None, world_if_parallel()
    if args.nonlinear:
        out["nonlinear"], curve = _nonlinear(model, cfg, response.grid, angles,
                                             args.harmonics, say, resonances, args.exact,
                                             world)
    failure = None
    if world is None or world.rank == 0:  # every rank holds the result: rank 0 tells it
        if args.json:
            print_json(out)
        else:
            _print(out)
        if args.out:  # after the numbers are printed: a full disk still leaves them
            failure = save_hdf5(args.out, lambda f: _fill(f, cfg, model, response, tuned, out,
                                                          angles, curve),
                                "the response is printed above")
    agree(world, failure)  # every rank stops together
    return 0


def _nonlinear_resonances(model, cfg, angles: dict | None, band, say) -> tuple:
    """``(band [Hz], resonances [rad/s])``: the excited ND's resonance with the contacts
    slipping and, under the elastic law, stuck (what :func:`_no_resonance` checks the band
    against), and ``band`` (``--frequencies``'), else ``forced.band_hz``'s (None), else from
    one resonance to the other widened (:func:`~wheelrom.studies.forced_nonlinear.
    nonlinear_band`, the design study's; the linear peak search's, the stuck resonance's
    +-1 %, misses the nonlinear one: the paper wheel at 1 N, 130 Hz against 146.8)."""
    import dataclasses

    from wheelrom.studies.forced_nonlinear import BAND_MARGIN, nonlinear_band

    whole = dataclasses.replace(cfg, forced=dataclasses.replace(cfg.forced, band_hz=()))
    (lo, hi), resonances = nonlinear_band(model, whole, angles, comm_self())
    if band is None and not cfg.forced.band_hz:
        band = (lo / (2 * math.pi), hi / (2 * math.pi))
        say(f"the band {band[0]:.5g}..{band[1]:.5g} Hz: the resonance with the contacts "
            f"{_resonance_words(resonances, ' to ')}, +-{BAND_MARGIN:.0%} (friction holds "
            "the nonlinear one between them; --frequencies sets another)")
    return band, resonances


def _resonance_words(found: list, sep: str) -> str:
    """``slipping 120.02 Hz<sep>stuck 256.58 Hz`` of the resonances ``found`` [rad/s]."""
    return sep.join(f"{name} {w / (2 * math.pi):.5g} Hz"
                    for name, w in zip(("slipping", "stuck"), found, strict=False))


def _shares(fractions: np.ndarray, kinds) -> dict:
    """Per contact kind its open / stick / slip shares of ``fractions`` ``(K, 3)``."""
    return {kind: dict(zip(("open", "stick", "slip"), map(float, fractions[k]), strict=True))
            for k, kind in enumerate(kinds)}


def _shares_words(shares: dict) -> str:
    """:func:`_shares` in words ("no contacts" without)."""
    return "; ".join(f"{kind} open {100 * s['open']:.0f} %, stick {100 * s['stick']:.0f} %, "
                     f"slip {100 * s['slip']:.0f} %" for kind, s in shares.items()) \
        or "no contacts"


def _speed_note(model, cfg) -> str:
    """What ``forced.over = "speed"`` does with this model, in one line."""
    from wheelrom.analysis.forced import speed_following

    if speed_following(model, cfg) is not None:
        return (f"over the rotor speed (excitation / {cfg.wheel.stator_vanes}): the stiffness "
                "follows it")
    return ("over the rotor speed: segment.prestress is off (or wheel.speed_hz = 0), the "
            "stiffness does not depend on the speed: the curve is the frequency's")


def summary(response, tuned, cfg, model, contacts: bool) -> dict:
    """What ``forced-response`` reports (plain data; ``--json``): the band, the coarse grid
    and its max-blade amplitudes, both refined peaks and the amplification factor."""
    from wheelrom.rom.model import nodal_diameter

    grid = response.grid_blade_amplitude.max(axis=1)
    tuned_grid = tuned.grid_blade_amplitude.max(axis=1)
    return {
        "stator_vanes": cfg.wheel.stator_vanes,
        "over": cfg.forced.over,  # "speed": the stiffness followed each frequency's speed
        "nodal_diameter": int(nodal_diameter(cfg.wheel.stator_vanes, model.blades)),
        "contacts": contacts,
        "mistuned": not model.tuned,
        "band_hz": list(response.band_hz),
        "frequency_hz": (response.grid / (2 * math.pi)).tolist(),
        "max_amplitude_m": grid.tolist(),
        "tuned_max_amplitude_m": tuned_grid.tolist(),
        "peak_amplitude_m": response.amplitude,
        "peak_frequency_hz": response.frequency_hz,
        "peak_blade_amplitude_m": response.blade_amplitude.tolist(),
        "tuned_peak_amplitude_m": tuned.amplitude,
        "tuned_peak_frequency_hz": tuned.frequency_hz,
        # the rotor speed at which the nozzle (engine order n_s) meets each peak [Hz]
        "peak_speed_hz": response.frequency_hz / cfg.wheel.stator_vanes,
        "tuned_peak_speed_hz": tuned.frequency_hz / cfg.wheel.stator_vanes,
        "amplification_factor": response.amplitude / tuned.amplitude,
        "grid_amplification_factor": float(grid.max() / tuned_grid.max()) if grid.size else None,
        "solves": response.solves,
        "tuned_solves": tuned.solves,
        "candidates": response.candidates,
        "refined": response.refined,
        "wall_s": response.wall_s,
        "solve_s_per_frequency": response.wall_s / max(response.solves, 1),
    }


def _nonlinear(model, cfg, grid: np.ndarray, angles: dict | None, harmonics: int,
               say, resonances: list, exact: str | None = None, world=None):
    """``(plain data, ForcedCurve)``: the nonlinear curve over the coarse grid (tip
    amplitude per frequency, Newton's verdict, the peak with its contacts' open / stick /
    slip shares, refined off the grid; ``exact`` (``--exact``; None: ``forced.exact``'s):
    ``"peak"`` the peak's exact state by shooting, ``"all"`` every solved frequency's too,
    ``"none"`` neither; ``resonances`` [rad/s]:
    :func:`_nonlinear_resonances`'). Under mpirun (``world``: mpi4py's COMM_WORLD) the grid's
    frequencies are shared in segments and the exact states dealt over the ranks; rank 0
    traces the curve."""
    from wheelrom.studies.forced_nonlinear import forced_inputs, nonlinear_forced

    rank = 0 if world is None else world.rank
    exact = {None: "peak" if cfg.forced.exact else None, "none": None}.get(exact, exact)
    outside = _no_resonance(model, cfg, grid, resonances)
    if outside:
        say(outside)
    ranks = f" over {world.size} ranks" if world is not None else ""
    say(f"the nonlinear response (harmonic balance, H = {harmonics}, "
        f"contacts.law = '{cfg.contacts.law}') at {grid.size} frequencies{ranks}")
    inputs = forced_inputs(model, cfg, angles, comm_self())  # the grid's and the trace's
    curve = nonlinear_forced(model, cfg, grid, angles, harmonics, comm_self(), inputs=inputs,
                             ranks=world, refine=True)
    amplitude = [float(a) if ok else None
                 for a, ok in zip(curve.tip_amplitude, curve.converged, strict=True)]
    out = {"law": cfg.contacts.law, "harmonics": harmonics, "tip_amplitude_m": amplitude,
           "converged": curve.converged.tolist(), "wall_s": curve.wall_s}
    if world is not None:
        out["resolved_seams_hz"] = [w / (2 * math.pi) for w in curve.resolved_seams]
    if outside:
        out["no_resonance"] = outside
    if cfg.forced.continuation == "arclength" and rank == 0:
        say("the curve traced by arclength over the same range")
        out["traced"] = _traced(model, cfg, curve, grid, inputs)
    if curve.converged.any():
        i = curve.peak
        if edge := edge_of(curve):  # a largest value, not a peak
            out["peak_at_edge"] = edge
        if outside:  # the linear resonances lie outside: where the nonlinear one is
            out["no_resonance"] = outside + (
                f"; the nonlinear response's largest value is at the band's "
                f"{out['peak_at_edge']} edge" if "peak_at_edge" in out else
                f"; the nonlinear response peaks inside it, at "
                f"{curve.frequency[i] / (2 * math.pi):.5g} Hz")
        r = curve.refined
        if r is not None and "peak_at_edge" not in out:  # the maximum off the grid
            out["refined_peak_amplitude_m"] = float(r.tip_amplitude)
            out["refined_peak_frequency_hz"] = float(r.frequency / (2 * math.pi))
            out["refined_peak_shares"] = _shares(r.fractions, curve.kinds)
        out["peak_amplitude_m"] = float(curve.tip_amplitude[i])
        out["peak_frequency_hz"] = float(curve.frequency[i] / (2 * math.pi))
        out["peak_speed_hz"] = out["peak_frequency_hz"] / cfg.wheel.stator_vanes
        out["peak_shares"] = _shares(curve.fractions[i], curve.kinds)
        states = _exact_states(model, cfg, curve, inputs, angles, harmonics, exact, world, say)
        if states:
            out["exact"] = states[i]
        if exact == "all":
            out["exact_curve"] = [states.get(j) for j in range(curve.frequency.size)]
    return out, curve


def _exact_states(model, cfg, curve, inputs: tuple, angles: dict | None, harmonics: int,
                  exact: str | None, world, say) -> dict:
    """``{grid index: plain data of the exact state}`` at the peak (``exact``) or at every
    solved frequency (``"all"``), dealt over the ranks of ``world`` (None: this process
    alone) in turn and gathered on every rank."""
    from wheelrom.studies.forced_nonlinear import exact_peak

    wanted = (np.flatnonzero(curve.converged) if exact == "all" else [curve.peak] if exact
              else [])
    size, rank = (1, 0) if world is None else (world.size, world.rank)
    states = {}
    for j in wanted[rank::size]:
        X, w = curve.harmonics[j], float(curve.frequency[j])
        refined = exact == "peak" and curve.refined is not None and not edge_of(curve)
        if refined:  # the peak off the grid: the balance's maximum, the shot's start
            X, w = curve.refined.harmonics, float(curve.refined.frequency)
        say(f"the exact state at {w / (2 * math.pi):.4f} Hz by shooting")
        states[int(j)] = _exact(exact_peak(model, cfg, X, w, harmonics, inputs, angles,
                                           whole_wheel=True, settle=True))
        states[int(j)]["at_refined_peak"] = refined
    if world is not None and len(wanted):
        states = {j: s for part in world.allgather(states) for j, s in part.items()}
    return states


def edge_of(curve) -> str:
    """'lower' or 'upper' where the curve's largest converged point is the first or last
    converged one of three or more (a largest value at the band's edge, not a peak), else
    ''."""
    solved = np.flatnonzero(curve.converged)
    if solved.size <= 2 or curve.peak not in (solved[0], solved[-1]):
        return ""
    return "lower" if curve.peak == solved[0] else "upper"


def _exact(orbit) -> dict:
    """Plain data of a :class:`~wheelrom.analysis.periodic.forced_shooting.ForcedOrbit`."""
    out = {"converged": orbit.converged, "residual": orbit.residual,
           "iterations": orbit.iterations, "reason": orbit.reason, "wall_s": orbit.wall_s,
           "frequency_hz": orbit.frequency / (2 * math.pi), "pattern_blades": orbit.pattern,
           "hb_tip_amplitude_m": orbit.hb_tip_amplitude}
    if orbit.converged:
        mu = orbit.multipliers
        out.update(tip_amplitude_m=orbit.tip_amplitude,
                   hb_relative_difference=orbit.relative_difference,
                   largest_multiplier=orbit.largest, stable=orbit.stable,
                   largest_multiplier_at_twice_the_step=orbit.coarse_largest,
                   multipliers_re=mu.real.tolist(), multipliers_im=mu.imag.tolist(),
                   multiplier_nd=orbit.nodal_diameters.tolist())
    if orbit.wheel_multipliers.size:  # every ND
        mu = orbit.wheel_multipliers
        out.update(wheel_largest_multiplier=float(abs(mu[0])),
                   wheel_multipliers_re=mu.real.tolist(), wheel_multipliers_im=mu.imag.tolist(),
                   wheel_multiplier_nd=orbit.wheel_nodal_diameters.tolist())
    if orbit.settled is not None:  # unstable: where the wheel goes
        st = orbit.settled
        out.update(settled_bounded=st.bounded, settled_periods=st.periods,
                   settled_largest_m=st.largest, settled_smallest_m=st.smallest,
                   settled_spread=st.spread, settled_deviation_m=st.deviation,
                   settled_nd=st.dominant_nd, settled_wall_s=st.wall_s)
    return out


def _traced(model, cfg, curve, grid: np.ndarray, inputs: tuple) -> dict:
    """The curve traced by arclength over the grid's range (plain data: the points in the
    order traced, null where a piece ends; the folds; Hill's growth under the paper law)."""
    from wheelrom.studies.forced_nonlinear import trace_after_grid

    traced = trace_after_grid(model, cfg, curve, (float(grid.min()), float(grid.max())), inputs)

    def listed(values):
        return [float(v) if ok and np.isfinite(v) else None
                for v, ok in zip(values, traced.converged, strict=True)]

    out = {"frequency_hz": listed(traced.frequency / (2 * math.pi)),
           "tip_amplitude_m": listed(traced.tip_amplitude), "growth_per_s": listed(traced.growth),
           "folds_hz": (traced.folds / (2 * math.pi)).tolist(), "end": traced.trace,
           "wall_s": traced.wall_s}
    if traced.refined is not None:
        out["peak_amplitude_m"] = traced.refined.tip_amplitude
        out["peak_frequency_hz"] = traced.refined.frequency / (2 * math.pi)
        edges = (float(grid.min()), float(grid.max()))
        at = [abs(traced.refined.frequency - e) <= 1e-9 * e for e in edges]
        if any(at):  # a largest value where the range ends, not a peak: the branch goes on
            out["peak_at_edge"] = "lower" if at[0] else "upper"
    return out


def _no_resonance(model, cfg, grid: np.ndarray, found: list) -> str:
    """One line when the frequencies ``grid`` [rad/s] hold neither resonance that friction
    keeps the peak between (the excited ND's ``forced.family`` with the contacts slipping
    and, under the elastic law, stuck: :func:`~wheelrom.studies.forced_nonlinear.
    nonlinear_band`); "" when they hold one."""
    from wheelrom.rom.model import nodal_diameter

    lo, hi = float(grid.min()), float(grid.max())
    if any(lo <= w <= hi for w in found):
        return ""
    where = _resonance_words(found, ", ")
    nd = int(nodal_diameter(cfg.wheel.stator_vanes, model.blades))
    if lo == hi:  # N = 1: the grid is the band's lower end alone, whatever the band
        return (f"no resonance at the grid's one frequency {lo / (2 * math.pi):.5g} Hz: the "
                f"ND {nd} family {cfg.forced.family} resonates with the contacts {where}; "
                "the nonlinear response is solved at the grid's frequencies only (give N > 1)")
    return (f"no resonance in {lo / (2 * math.pi):.5g}..{hi / (2 * math.pi):.5g} Hz: the ND "
            f"{nd} family {cfg.forced.family} resonates with the contacts {where}; the "
            "linear response computed here is off resonance")


def _fill(f, cfg, model, response, tuned, out: dict, angles: dict | None,
          curve=None) -> None:
    """The response into the open HDF5 file ``f`` (docs/output.md, format
    ``wheelrom-forced-1``): ``frequency_hz`` ``(F,)`` (the coarse grid), ``blade_amplitude``
    and ``tuned_blade_amplitude`` ``(F, N)`` [m] on it, ``peak_blade_amplitude`` and
    ``tuned_peak_blade_amplitude`` ``(N,)`` [m] at the refined peaks, ``mistuning``
    ``(N,)``; attributes: the configuration and its source, the wheelrom version, the
    scalars of ``out``, the model size, the contact angles (JSON) and the KSP settings
    (``solver``, JSON: :func:`wheelrom.analysis.forced.ksp_settings`); with ``--nonlinear``
    the group ``/nonlinear`` (``curve``: :func:`_write_nonlinear`)."""
    import json

    from wheelrom import __version__
    from wheelrom import config as config_mod
    from wheelrom.results.file_checksums import write_file_checksums

    f.attrs["format"] = FORMAT
    f.attrs["config"] = config_mod.to_toml(cfg)
    f.attrs["config_source"] = cfg.source
    f.attrs["wheelrom_version"] = __version__
    for key in ("stator_vanes", "over", "nodal_diameter", "contacts", "mistuned",
                "amplification_factor", "solve_s_per_frequency", "band_hz",
                "peak_amplitude_m", "peak_frequency_hz", "tuned_peak_amplitude_m",
                "tuned_peak_frequency_hz", "peak_speed_hz", "tuned_peak_speed_hz",
                "solves"):
        f.attrs[key] = out[key]
    f.attrs["blades"], f.attrs["modes"] = model.blades, model.modes
    f.attrs["contact_angles_deg"] = json.dumps(_contact_angles(cfg, angles) if out["contacts"]
                                               else {})
    f.attrs["solver"] = json.dumps(response.solver)
    f["frequency_hz"] = np.asarray(out["frequency_hz"])
    f["blade_amplitude"] = response.grid_blade_amplitude
    f["tuned_blade_amplitude"] = tuned.grid_blade_amplitude
    f["peak_blade_amplitude"] = response.blade_amplitude
    f["tuned_peak_blade_amplitude"] = tuned.blade_amplitude
    mistuning = model.mistuning if model.mistuning is not None else np.zeros(model.blades)
    f["mistuning"] = mistuning
    if curve is not None:
        _write_nonlinear(f.create_group("nonlinear"), out["nonlinear"], curve)
    write_file_checksums(f)


def _write_nonlinear(g, out: dict, curve) -> None:
    """``/nonlinear``: ``tip_amplitude`` ``(F,)`` [m] (NaN where Newton failed),
    ``converged`` ``(F,)``, ``harmonics`` ``(F, 2H + 1, m)`` blade 0's packed harmonics
    [sqrt(kg) m], ``contact_shares`` ``(F, K, 3)`` open / stick / slip of each kind;
    attributes ``law``, ``harmonics``, ``kinds`` (JSON), the peak's amplitude and frequency
    when one converged."""
    import json

    g.attrs["law"], g.attrs["harmonics"] = out["law"], out["harmonics"]
    g.attrs["kinds"] = json.dumps(list(curve.kinds))
    for key in ("peak_amplitude_m", "peak_frequency_hz"):
        if key in out:
            g.attrs[key] = out[key]
    g["tip_amplitude"] = curve.tip_amplitude
    g["converged"] = curve.converged
    g["harmonics"] = curve.harmonics
    g["contact_shares"] = curve.fractions
    if "traced" in out:  # forced.continuation = "arclength"
        traced, t = out["traced"], g.create_group("traced")
        for key in ("frequency_hz", "tip_amplitude_m", "growth_per_s"):
            t[key] = np.array([np.nan if v is None else v for v in traced[key]])
        t["folds_hz"] = np.asarray(traced["folds_hz"], dtype=float)
        t.attrs["end"] = traced["end"]
        for key in ("peak_amplitude_m", "peak_frequency_hz"):
            if key in traced:
                t.attrs[key] = traced[key]
    if "exact_curve" in out:  # --exact all: per grid frequency, NaN where not solved
        rows, e = out["exact_curve"], g.create_group("exact_curve")
        for key in ("tip_amplitude_m", "hb_relative_difference", "wheel_largest_multiplier"):
            e[key] = np.array([r[key] if r and key in r else np.nan for r in rows], dtype=float)
        e["wheel_multiplier_nd"] = np.array([r["wheel_multiplier_nd"][0]
                                             if r and "wheel_multiplier_nd" in r else -1
                                             for r in rows], dtype="i8")
        for key in ("settled_largest_m", "settled_spread"):  # NaN: stable or not settled
            e[key] = np.array([r[key] if r and key in r else np.nan for r in rows], dtype=float)
        e["stable"] = np.array([bool(r and r.get("stable")) for r in rows])
        e["converged"] = np.array([bool(r and r["converged"]) for r in rows])
    if "exact" in out:  # --exact
        exact, e = out["exact"], g.create_group("exact")
        for key, value in exact.items():
            if key.startswith(("multiplier", "wheel_multiplier")):
                e[key] = np.asarray(value)
            else:
                e.attrs[key] = value


def _contact_angles(cfg, angles: dict | None) -> dict:
    """kind -> contact angle [deg] of every enabled kind: ``--angle`` or the configured one."""
    return {k: float((angles or {}).get(k, getattr(cfg.contacts, k).angle_deg))
            for k in cfg.contacts.enabled_kinds()}


def _print(out: dict) -> None:
    """A table per frequency of the coarse grid, then the refined peaks and the
    amplification factor."""
    print(f"engine order {out['stator_vanes']} (ND {out['nodal_diameter']}), contacts "
          f"{'linearised' if out['contacts'] else 'off'}, "
          f"{'mistuned' if out['mistuned'] else 'tuned'} wheel, over the {out['over']}")
    print(f"{'f [Hz]':>12s} {'max tip [m]':>12s} {'tuned [m]':>12s} {'ratio':>8s}")
    rows = zip(out["frequency_hz"], out["max_amplitude_m"], out["tuned_max_amplitude_m"],
               strict=True)
    for f, a, t in rows:
        print(f"{f:12.4f} {a:12.4e} {t:12.4e} {a / max(t, 1e-300):8.4f}")
    lo, hi = out["band_hz"]
    print(f"refined peak over {lo:.6g}..{hi:.6g} Hz: max-blade amplitude "
          f"{out['peak_amplitude_m']:.6e} m at {out['peak_frequency_hz']:.6f} Hz, tuned "
          f"{out['tuned_peak_amplitude_m']:.6e} m at {out['tuned_peak_frequency_hz']:.6f} Hz: "
          f"amplification factor {out['amplification_factor']:.5f}")
    print(f"rotor speeds of the peaks (engine order {out['stator_vanes']}): "
          f"{out['peak_speed_hz']:.6f} Hz ({60 * out['peak_speed_hz']:.2f} rpm), tuned "
          f"{out['tuned_peak_speed_hz']:.6f} Hz ({60 * out['tuned_peak_speed_hz']:.2f} rpm)")
    if "nonlinear" in out:
        _print_nonlinear(out)


def _print_nonlinear(out: dict) -> None:
    """The nonlinear tip amplitude beside the linear one at every frequency, its peak."""
    nl = out["nonlinear"]
    print(f"nonlinear (harmonic balance, H = {nl['harmonics']}, contacts.law = "
          f"'{nl['law']}', {nl['wall_s']:.1f} s):")
    exact = nl.get("exact_curve") or [None] * len(out["frequency_hz"])
    print(f"{'f [Hz]':>12s} {'linear [m]':>12s} {'nonlinear [m]':>14s}"
          + (f" {'exact [m]':>12s} {'|mu| (ND)':>16s} {'settles':>9s}" if "exact_curve" in nl
             else ""))
    rows = zip(out["frequency_hz"], out["max_amplitude_m"], nl["tip_amplitude_m"], exact,
               strict=True)
    for f, a, b, ex in rows:
        text = f"{b:14.4e}" if b is not None else f"{'no solution':>14s}"
        if ex is not None and ex["converged"]:  # --exact all
            mu = f"{ex['wheel_largest_multiplier']:.4f} ({ex['wheel_multiplier_nd'][0]})"
            text += f" {ex['tip_amplitude_m']:12.4e} {mu:>16s}" + _settles(ex)
        elif ex is not None:
            text += f" {'no orbit':>12s}"
        print(f"{f:12.4f} {a:12.4e} {text}")
    if "peak_amplitude_m" in nl:
        edge = nl.get("peak_at_edge")
        where = (f"nonlinear largest value at the band's {edge} edge (the resonance lies "
                 f"{'below' if edge == 'lower' else 'above'} it: widen --frequencies)"
                 if edge else "nonlinear peak on the grid")
        print(f"{where}: {nl['peak_amplitude_m']:.4e} m at "
              f"{nl['peak_frequency_hz']:.4f} Hz, speed {nl['peak_speed_hz']:.4f} Hz "
              f"({_shares_words(nl['peak_shares'])})")
    if "refined_peak_amplitude_m" in nl:
        print(f"refined nonlinear peak: {nl['refined_peak_amplitude_m']:.6e} m at "
              f"{nl['refined_peak_frequency_hz']:.6f} Hz "
              f"({_shares_words(nl['refined_peak_shares'])})")
    if "exact" in nl:
        _print_exact(nl["exact"])
    if "traced" in nl:
        tr = nl["traced"]
        folds = ("folds at " + ", ".join(f"{f:.4f}" for f in tr["folds_hz"]) + " Hz"
                 if tr["folds_hz"] else "no fold")
        peak = (f"peak {tr['peak_amplitude_m']:.4e} m at {tr['peak_frequency_hz']:.4f} Hz; "
                if "peak_amplitude_m" in tr else "")
        if "peak_at_edge" in tr:
            peak = (f"largest {tr['peak_amplitude_m']:.4e} m at the range's "
                    f"{tr['peak_at_edge']} edge, {tr['peak_frequency_hz']:.4f} Hz (a branch "
                    f"goes on {'below' if tr['peak_at_edge'] == 'lower' else 'above'} it); ")
        unstable = sum(g is not None and g > 0 for g in tr["growth_per_s"])
        print(f"traced by arclength: {sum(f is not None for f in tr['frequency_hz'])} points "
              f"in {tr['wall_s']:.1f} s, {peak}{folds}, {unstable} unstable "
              f"points (Hill); {tr['end']}")
    if "no_resonance" in nl:
        print(nl["no_resonance"])
    print(f"{out['solves']} solves ({out['candidates']} candidates, {out['refined']} refined), "
          f"{1e3 * out['solve_s_per_frequency']:.3g} ms per solve")


def _print_exact(ex: dict) -> None:
    """The exact state's line: its amplitude against the balance's, its multipliers."""
    if not ex["converged"]:
        print(f"exact state at {ex['frequency_hz']:.4f} Hz: shooting did not converge "
              f"({ex['reason']}, residual {ex['residual']:.2g})")
        return
    if not ex["multiplier_nd"]:  # converged, its multipliers failed (the reason says how)
        print(f"exact state at {ex['frequency_hz']:.4f} Hz: tip {ex['tip_amplitude_m']:.4e} m, "
              f"the harmonic balance {100 * ex['hb_relative_difference']:+.3f} %; no "
              f"multipliers ({ex['reason']})")
        return
    verdict = "stable" if ex["stable"] else "unstable"
    every = (f"; in every ND |mu| = {ex['wheel_largest_multiplier']:.6f} (ND "
             f"{ex['wheel_multiplier_nd'][0]})" if "wheel_largest_multiplier" in ex else "")
    if "settled_bounded" in ex:
        verdict += _settled_words(ex)
    where = "the refined peak, " if ex.get("at_refined_peak") else ""
    print(f"exact state at {where}{ex['frequency_hz']:.4f} Hz (shooting, {ex['iterations']} "
          f"iterations, residual {ex['residual']:.1e}, {ex['wall_s']:.1f} s): tip "
          f"{ex['tip_amplitude_m']:.4e} m, the harmonic balance "
          f"{100 * ex['hb_relative_difference']:+.3f} %; largest Floquet multiplier "
          f"|mu| = {ex['largest_multiplier']:.6f} (ND {ex['multiplier_nd'][0]}; "
          f"{ex['largest_multiplier_at_twice_the_step']:.6f} at twice the step) within the "
          f"NDs of its {ex['pattern_blades']}-blade pattern{every}: {verdict}")


def _settles(ex: dict) -> str:
    """The table's column: the largest blade where the wheel goes from an unstable state,
    over the state's (blank: stable; 'unbounded': it did not saturate)."""
    if "settled_bounded" not in ex:
        return ""
    if not ex["settled_bounded"]:
        return f" {'unbounded':>9s}"
    change = 100 * (ex["settled_largest_m"] / ex["tip_amplitude_m"] - 1)
    return f" {change:+8.2f}%"


def _settled_words(ex: dict) -> str:
    """Where the wheel goes from the unstable state, in words."""
    change = 100 * (ex["settled_largest_m"] / ex["tip_amplitude_m"] - 1)
    motion = (f"the largest blade {ex['settled_largest_m']:.4e} m ({change:+.2f} %), the "
              f"blades {100 * ex['settled_spread']:.2f} % apart, the tips within "
              f"{100 * ex['settled_deviation_m'] / ex['tip_amplitude_m']:.2f} % of the "
              f"state's amplitude from it, the difference mostly ND {ex['settled_nd']}")
    if ex["settled_bounded"]:
        return (f"; perturbed, the wheel leaves it and stays bounded after "
                f"{ex['settled_periods']} periods ({ex['settled_wall_s']:.0f} s): {motion}")
    return (f"; perturbed, the wheel leaves it, not bounded after {ex['settled_periods']} "
            f"periods: {motion}")
