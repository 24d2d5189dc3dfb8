#!/usr/bin/env python
"""Scripted TS option tuning: one model, many PETSc TS settings, accuracy against wall time.

Builds the reduced model once (library API), runs the same case with each TS setting through
``wheelrom.transient.run.run_case(model, cfg, options=...)``, and compares the final blade-tip
displacements of every blade with a fine-step reference (RK 5dp at a sixteenth of the step),
whose own error (against twice its step) is reported as the floor of the comparison.
This is also the work-precision study of ``docs/performance.md``.

Every run starts from the preloaded static equilibrium with a small perturbation
(``--perturbation``, largest tip displacement [m]; ``time.start = "preload"``), where the
solution is a smooth function of the step. A start from rest applies the contact preloads
as a step load; the contacts then open and close thousands of times and that start-up is
chaotic, so final states of runs from rest measure the chaos, not the scheme: ``--lyapunov``
estimates it instead (two runs from rest whose starts differ by 1e-12 m, the growth rate of
their tip separation per time interval).

    .venv/bin/python run/tune_ts.py [CONFIG] [--set key=value ...] [--end 0.02]
                                    [--perturbation 1e-9] [--lyapunov]
                                    [--json] [--plot work_precision.png]
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from wheelrom.runtime.environment import bootstrap

bootstrap()  # before numpy's BLAS loads: one thread per process

import numpy as np  # noqa: E402

from wheelrom import config  # noqa: E402
from wheelrom.rom.build import build_model, quiet  # noqa: E402
from wheelrom.runtime.environment import petsc  # noqa: E402
from wheelrom.runtime.errors import InputError  # noqa: E402
from wheelrom.transient.run import run_case  # noqa: E402
from wheelrom.transient.ts import time_step  # noqa: E402

RK_STEP = 3e-6  # [s] the paper's RK 3bs step on the default wheel (its limit: 4.2 us)
GRID = 120e-6  # [s] every compared step divides it: the runs end at the same instant
REFERENCE_STEP = 7.5e-7  # [s] RK 5dp: the fine reference


def settings(step: float) -> list[tuple[str, dict]]:
    """The TS settings compared: the exponential scheme (the default) at 2x..1/4x of its step,
    fixed-step RK 3bs at 4x..1/4x of ``RK_STEP`` (the larger ones are refused: beyond RK's
    stability), RK4 at 6 us, adaptive RK types."""
    out = [(f"exponential dt={dt:.3g}", {"ts_dt": dt}) for dt in
           (2 * step, step, step / 2, step / 4)]
    rk = {"ts_type": "rk"}
    out += [(f"3bs dt={dt:.3g}", {**rk, "ts_rk_type": "3bs", "ts_dt": dt}) for dt in
            (4 * RK_STEP, 2 * RK_STEP, RK_STEP, RK_STEP / 2, RK_STEP / 4)]
    out.append(("4 dt=6e-06", {**rk, "ts_rk_type": "4", "ts_dt": 6e-6}))
    for kind in ("3bs", "5dp"):
        for rtol in (1e-4, 1e-6, 1e-8):
            opts = {**rk, "ts_rk_type": kind, "ts_adapt_type": "basic", "ts_rtol": rtol,
                    "ts_atol": rtol * 1e-3, "ts_dt": RK_STEP}
            out.append((f"{kind} adaptive rtol={rtol:.0e}", opts))
    return out


def final_tip(model, res) -> np.ndarray:
    n = model.size
    return res.final_state[:n].reshape(model.blades, model.modes) @ model.tip.T


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("config", nargs="?", help="TOML configuration (default: built-in case)")
    ap.add_argument("--set", dest="overrides", action="append", default=[])
    ap.add_argument("--end", type=float, default=0.02, help="simulated time per run [s]")
    ap.add_argument("--perturbation", type=float, default=1e-9,
                    help="start: the preloaded equilibrium plus a random perturbation of this "
                    "largest tip displacement [m]")
    ap.add_argument("--lyapunov", action="store_true",
                    help="instead: the finite-time Lyapunov exponent of the start from rest")
    ap.add_argument("--json", action="store_true", help="print the table as JSON")
    ap.add_argument("--plot", help="write a work-precision figure (PNG)")
    args = ap.parse_args(argv)
    cfg = config.load(args.config, args.overrides)
    cfg = cfg.replace(**{"time.end": args.end, "time.window": args.end})
    model = build_model(cfg, petsc().COMM_SELF, log=quiet if args.json else print)
    if args.lyapunov:
        return lyapunov(model, cfg, args.json)
    cfg = cfg.replace(**{"time.start": "preload", "time.perturbation": args.perturbation})
    step = time_step(cfg)  # the TS's step: -wheel_ts_dt overrides time.step
    # an end every fixed step reaches exactly: the runs are compared at the same instant (a
    # 0.1 us offset alone gives ~1e-3 of tip error on the default wheel)
    end = max(1, round(args.end / GRID)) * GRID
    cfg = cfg.replace(**{"time.end": end, "time.window": end})
    run_case(model, cfg.replace(**{"time.end": 20 * step, "time.window": 20 * step}))
    # the reference twice, at its step and at half of it: the finer one is the reference,
    # their difference its own error (the floor below which no error measured against it
    # means anything; it differs between CPUs through rounding)
    tips = []
    for dt in (REFERENCE_STEP, REFERENCE_STEP / 2):
        reference = run_case(model, cfg, options={"ts_type": "rk", "ts_rk_type": "5dp",
                                                  "ts_dt": dt})
        if reference.status != "done":
            print(f"reference run failed: {reference.status}", file=sys.stderr)
            return 1
        tips.append(final_tip(model, reference))
    tip_ref = tips[1]
    scale = float(np.abs(tip_ref).max())
    reference_error = float(np.abs(tips[0] - tip_ref).max() / scale)
    if not args.json:
        print(f"reference: RK 5dp dt={REFERENCE_STEP / 2:.3g}, its own error "
              f"{reference_error:.2e} (against dt={REFERENCE_STEP:.3g})")
    rows = []
    for label, opts in settings(step):
        t0 = time.perf_counter()
        scheme = "exponential" if label.startswith("exponential") else "rk"
        try:
            res = run_case(model, cfg.replace(**{"time.scheme": scheme}), options=opts)
        except InputError as exc:  # a fixed step beyond the explicit scheme's stability
            print(f"{label:28s} refused: {exc}", file=sys.stderr)
            continue
        wall = time.perf_counter() - t0
        error = (
            float(np.abs(final_tip(model, res) - tip_ref).max() / scale)
            if res.status == "done"
            else float("nan")
        )
        rows.append({
            "setting": label, "options": res.options, "status": res.status,
            "steps": res.steps, "rhs_evaluations": res.rhs_evaluations, "wall_s": wall,
            "tip_error": error, "energy_balance_error": res.energy_balance_error(),
        })
        if not args.json:
            print(f"{label:28s} {res.status:6s} steps {res.steps:7d}  wall {wall:7.3f} s  "
                  f"tip error {error:9.2e}")
    if args.json:
        table = {"end_s": cfg.time.end, "reference": f"5dp dt={REFERENCE_STEP / 2}",
                 "reference_error": reference_error, "runs": rows}
        json.dump(table, sys.stdout, indent=1, default=str)
        sys.stdout.write("\n")
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        for family, marker in (("exponential dt", "D"), ("3bs dt", "o"), ("3bs adaptive", "s"),
                               ("5dp adaptive", "^")):
            pts = [(r["wall_s"], r["tip_error"]) for r in rows if r["setting"].startswith(family)]
            if pts:
                x, y = zip(*pts, strict=True)
                ax.loglog(x, y, marker=marker, label=family.replace(" dt", " fixed step"))
        ax.set_xlabel("wall time [s]")
        ax.set_ylabel("relative tip error at t_end [-]")
        ax.set_title(f"work-precision, {model.blades} blades x {model.modes} modes, "
                     f"{args.end * 1e3:.0f} ms")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(args.plot, dpi=110)
    return 0


def lyapunov(model, cfg, as_json: bool) -> int:
    """Two runs from rest, one with a 1e-12 m start perturbation: the growth rate [1/s] of
    their largest tip separation over each decade of time (finite-time Lyapunov exponents).
    """
    rest = cfg.replace(**{"time.start": "rest", "output.history_rate_hz": 0.0})
    step = time_step(rest)
    every = max(1, round(2e-4 / step))  # a tip sample every ~0.2 ms
    rest = rest.replace(**{"output.sample_rate_hz": 1.0 / (every * step),
                           "output.history_rate_hz": 1.0 / (every * step)})
    a = run_case(model, rest)
    b = run_case(model, rest.replace(**{"time.perturbation": 1e-12}))
    t = a.sample_time
    gap = np.abs(a.tip_history - b.tip_history).max(axis=(1, 2))
    rows = []
    for lo, hi in ((1e-3, 1e-2), (1e-2, 4e-2), (4e-2, 1e-1)):
        pick = (t >= lo) & (t <= min(hi, t[-1])) & (gap > 0)
        if pick.sum() >= 3 and t[-1] > lo:
            rate = float(np.polyfit(t[pick], np.log(gap[pick]), 1)[0])
            rows.append({"from_s": lo, "to_s": float(min(hi, t[-1])), "exponent_per_s": rate})
    if as_json:
        json.dump({"lyapunov": rows, "step_s": step}, sys.stdout, indent=1)
        sys.stdout.write("\n")
    for r in [] if as_json else rows:
        print(f"{r['from_s'] * 1e3:5.1f}..{r['to_s'] * 1e3:5.1f} ms: finite-time Lyapunov "
              f"exponent {r['exponent_per_s']:7.1f} /s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
