"""The harmonic balance against the exact orbit as the harmonics grow (docs/results.md, "The
harmonic balance against the exact orbit"): one case of a limit-cycle file with an exact orbit
(``method`` ``shooting``), its equations checked against the transient's on the orbit's states,
then Newton at the configured intensity from the orbit's own harmonics at every ``H`` asked.

    .venv/bin/python run/hb_truncation.py out/paper-limit-cycle.h5 --case 5 --harmonics 11,41,61

Samples per period: 32 (H + 1) unless ``--samples`` (the balance is then free of aliasing).
Minutes per solve above H = 40 on the paper wheel.
"""

import argparse
import math
import time

from wheelrom.runtime.environment import bootstrap

bootstrap()

import h5py  # noqa: E402
import numpy as np  # noqa: E402

from wheelrom.analysis.periodic.flow import WheelFlow, pattern_model  # noqa: E402
from wheelrom.analysis.periodic.harmonic_balance import WaveBalance  # noqa: E402
from wheelrom.analysis.periodic.limit_cycle import periodic_solution  # noqa: E402
from wheelrom.analysis.stability import linearise  # noqa: E402
from wheelrom.results.layout import read_config  # noqa: E402
from wheelrom.rom.build import build_model  # noqa: E402
from wheelrom.runtime.environment import petsc  # noqa: E402


def orbit_of(path: str, case: int):
    """``(cfg, angles, wave, state0 (2, N', m), period [s], orbit tip [m])`` of the case's
    first exact orbit."""
    with h5py.File(path, "r") as f:
        cfg = read_config(f, path)
        tieboss, shroud = f["limit_cycle/angles_deg"][case]
        group = f[f"limit_cycle/case_{case}"]
        for name in group:
            cycles = group.get(f"{name}/cycles")
            if cycles is None or "orbit_state" not in cycles:
                continue
            for k, method in enumerate(cycles["method"][()]):
                if method == b"shooting":
                    return (cfg, {"tieboss": float(tieboss), "shroud": float(shroud)},
                            int(group[name].attrs["wave"]), cycles["orbit_state"][k],
                            float(cycles["orbit_period"][k]), float(cycles["tip_amplitude"][k]))
    raise SystemExit(f"{path}: case {case} has no exact orbit (limit_cycle.method = 'shooting')")


def blade0_harmonics(q: np.ndarray, H: int) -> np.ndarray:
    """Packed ``(2H + 1, m)`` harmonics of blade 0's samples ``q`` ``(n, m)`` over a period."""
    n = q.shape[0]
    tau = 2 * math.pi * np.arange(n) / n
    X = np.zeros((2 * H + 1, q.shape[1]))
    X[0] = q.mean(axis=0)
    for h in range(1, H + 1):
        X[2 * h - 1] = 2 / n * (np.cos(h * tau)[:, None] * q).sum(axis=0)
        X[2 * h] = -2 / n * (np.sin(h * tau)[:, None] * q).sum(axis=0)
    return X


def tip_amplitude(balance: WaveBalance, X: np.ndarray, tip: np.ndarray) -> float:
    y = balance.E[0] @ X @ tip.T
    return float(np.linalg.norm(y - y.mean(axis=0), axis=1).max())


def same_equations(flow, balance, traj, model, beta) -> float:
    """Largest difference of blade 0's acceleration, transient against balance, over the
    orbit's states, relative to the largest acceleration (wave with a two-blade pattern)."""
    worst, scale = 0.0, 0.0
    for x in traj[::4]:
        a_ts = flow.vector_field(x)[1, 0]
        nxt = x[:, 1 % x.shape[1]]
        prv = x[:, -1 % x.shape[1]]
        qw = np.ascontiguousarray(np.stack([x[0, 0], nxt[0], prv[0]])[None])
        vw = np.ascontiguousarray(np.stack([x[1, 0], nxt[1], prv[1]])[None])
        force = balance._evaluate(qw, vw, 1.0)[0][0]
        w0, w1, w2 = (s[0] + beta * s[1] for s in (x[:, 0], nxt, prv))
        a_hb = force - (model.A0 @ w0 + model.A1 @ w1 + model.A1.T @ w2)
        worst, scale = max(worst, np.abs(a_ts - a_hb).max()), max(scale, np.abs(a_ts).max())
    return worst / scale


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("file")
    p.add_argument("--case", type=int, default=0)
    p.add_argument("--harmonics", default="11,41,61")
    p.add_argument("--samples", type=int, default=0)
    args = p.parse_args()
    cfg, angles, wave, state0, period, orbit_tip = orbit_of(args.file, args.case)
    model = build_model(cfg, petsc().COMM_SELF)
    params = linearise(model, cfg, angles, None)[0]
    beta = cfg.wheel.damping_beta
    flow = WheelFlow(pattern_model(model, wave)[0], cfg, angles)
    n, _ = flow.steps_for(period)
    traj = flow.trajectory(state0, period, n)
    omega = 2 * math.pi / period
    print(f"case {args.case} ({angles}), wave {wave}: orbit tip {orbit_tip * 1e6:.3f} um, "
          f"{1 / period:.3f} Hz, {n} steps a period")
    check = WaveBalance(model, params, beta, wave, 11, 96)
    differ = same_equations(flow, check, traj, model, beta)
    print(f"same equations: blade 0's accelerations differ by {differ:.1e} of the largest")
    print(" H  samples  HB tip [um]  vs orbit  HB f [Hz]  wall [s]")
    for H in (int(h) for h in args.harmonics.split(",")):
        balance = WaveBalance(model, params, beta, wave, H, args.samples or 32 * (H + 1))
        t0 = time.perf_counter()
        point = periodic_solution(balance, blade0_harmonics(traj[:-1, 0, 0], H), omega)
        if point is None:
            print(f"{H:3d}  Newton did not converge")
            continue
        amp = tip_amplitude(balance, point.X, model.tip)
        print(f"{H:3d} {balance.nt:8d} {amp * 1e6:12.3f} {amp / orbit_tip - 1:+9.1%} "
              f"{point.omega / (2 * math.pi):10.3f} {time.perf_counter() - t0:9.0f}", flush=True)
    flow.destroy()


if __name__ == "__main__":
    main()
