"""``wheelrom limit-cycle``: parse, call :func:`wheelrom.studies.limit_cycles.run_limit_cycles`,
write and format."""

from __future__ import annotations

import argparse

from wheelrom.cli.args import json_out, load_config, locked
from wheelrom.cli.output import log, report_and_save, throttled
from wheelrom.runtime.errors import InputError
from wheelrom.runtime.outputs import agree, check_output

PROGRESS_EVERY_S = 5.0  # a progress line at most this often


def args_limit_cycle(p: argparse.ArgumentParser) -> None:
    json_out(p)
    p.add_argument("--out", help="write the branches and cycles to this HDF5 file")
    p.add_argument("--nd", help="travelling waves to analyse, e.g. '33' or '5,33,61' (blade s+1 "
                   "leads by 2 pi k / N; ND k and N-k are the two directions), or 'fastest' "
                   "(the fastest-growing wave of each case); default limit_cycle.waves, else "
                   "every unstable one")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")


def _waves(text: str | None):
    """``--nd``: wave indices ``0..N-1``, ``-1`` or ``fastest`` for the fastest-growing one
    (as ``limit_cycle.waves``); an empty item (``5,,6``) is refused, not skipped."""
    if text is None:
        return None
    from wheelrom.analysis.periodic.limit_cycle import FASTEST

    if text.strip() == "fastest":
        return (FASTEST,)
    parts = [t.strip() for t in text.split(",")]
    if not parts or not all(t.isdigit() or t == "-1" for t in parts):
        raise InputError(f"--nd: '{text}' is not a list of wave indices (0, 1, ..., or -1 / "
                         "'fastest' for the fastest-growing one)")
    return tuple(int(t) for t in parts)


@locked("--out")
def cmd_limit_cycle(args: argparse.Namespace) -> int:
    """How far the flutter grows: the friction-held limit cycles per travelling wave (nozzle
    off, tuned wheel). The harmonic balance finds them: the Hopf point of every unstable
    wave, the branch of periodic solutions from there in the self-excitation's intensity and
    the cycles at the configured intensity. Each such cycle is then made exact by shooting on
    the transient's own equations and steps, and its stability is the whole wheel's Floquet
    multipliers (limit_cycle.method = 'shooting', the default; 'hb': the balance's cycles
    alone, Floquet by Hill's method). Under contacts.law = 'elastic' the exact orbit is
    marched on the wave's pattern wheel and shot with the sliders in the state, without a
    balance. Per cycle: tip amplitude, frequency, contact states, energy per cycle,
    stability. Under mpirun the cases go to the ranks as they become free."""
    from wheelrom.rom.build import quiet
    from wheelrom.studies.limit_cycles import run_limit_cycles, summary
    from wheelrom.studies.stability import world_if_parallel

    cfg = load_config(args)
    waves = _waves(args.nd)
    if waves and any(k >= cfg.wheel.blades for k in waves):
        raise InputError(f"--nd: waves {list(waves)} must be below wheel.blades = "
                         f"{cfg.wheel.blades}")
    if args.out:
        check_output(args.out, args.force)
    from wheelrom.results.limit_cycles import write_limit_cycles

    comm = world_if_parallel()
    progress = None if args.json else throttled(PROGRESS_EVERY_S)
    model, cases = run_limit_cycles(cfg, comm, log=quiet if args.json else log, waves=waves,
                                    progress=progress)
    failure = None
    if cases:  # rank 0: every case
        failure = report_and_save([summary(c) for c in cases], args.json, print_limit_cycles,
                                  args.out, lambda f: write_limit_cycles(f, cfg, model, cases))
    agree(comm, failure)  # every rank stops together, none waits for rank 0's file
    return 1 if any(c.failure for c in cases) else 0


def print_limit_cycles(rows: list[dict]) -> None:
    """One line per case (its verdict), then one per wave analysed."""
    for case in rows:
        angles = ", ".join(f"{k} {v:g} deg" for k, v in case["angles_deg"].items())
        print(f"{angles}: {case['verdict']}")
        for w in case["waves"]:
            direction = "forward" if w["direction"] > 0 else "backward"
            hopf = ("" if w["critical_mu_factor"] is None else
                    f", Hopf at {w['critical_mu_factor']:.4g} x mu, {w['hopf_hz']:.4g} Hz")
            print(f"    wave {w['wave']} (ND {w['nodal_diameter']} {direction}{hopf}): "
                  f"{w['verdict']}")
            for c in w["cycles"]:
                stable = {True: "stable", False: "unstable",
                          None: "stability uncertain" if "floquet" in c else
                          "stability not computed"}[c["stable"]]
                shot = c.get("shooting", {}).get("converged")  # None: shooting not tried
                how = {None: "", True: " (exact orbit)", False: f" by {c['source']}"}[shot]
                print(f"        cycle {c['tip_amplitude_m'] * 1e6:.4g} um tip, "
                      f"{c['frequency_hz']:.5g} Hz{how}, {stable}, energy balance "
                      f"{c['energy_residual']:.1e}")
