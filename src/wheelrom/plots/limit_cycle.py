"""Figures of a limit-cycle file (``wheelrom limit-cycle --out``): per case the branches of
every wave (tip amplitude against the factor on the self-excitation, stable / unstable where
Floquet was computed, the cycles at the configured intensity marked), their amplitude-dependent
damping, and over the cases the amplitude each settles at."""

from __future__ import annotations

import numpy as np

from wheelrom.plots.helpers import save


def limit_cycle_figures(f, path: str, outdir: str, pdf: bool, written: list[str], plt) -> None:
    g = f["limit_cycle"]
    angles = g["angles_deg"][()]
    for i in range(angles.shape[0]):
        case = g.get(f"case_{i}")
        waves = [case[k] for k in sorted(case, key=_wave_index) if k.startswith("wave_")] \
            if case is not None else []
        waves = [w for w in waves if "branch" in w]
        if not waves:
            continue
        label = f"tie-boss {angles[i, 0]:g} deg, shroud {angles[i, 1]:g} deg"
        _branches(waves, label, plt, outdir, f"limit_cycle_branches_case{i}", pdf, written)
        _damping(waves, label, plt, outdir, f"limit_cycle_damping_case{i}", pdf, written)
    if angles.shape[0] > 1:
        _amplitude_over_cases(g, angles, plt, outdir, pdf, written)


def _wave_index(name: str) -> int:
    return int(name.split("_")[1]) if name.startswith("wave_") else -1


def _branches(waves, label, plt, outdir, name, pdf, written) -> None:
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    for w in waves:
        b = w["branch"]
        lam, amp, stable = b["lam"][()], b["tip_amplitude"][()] * 1e6, b["stable"][()]
        segment = b["segment"][()]
        line = None
        for s in np.unique(segment):
            sel = segment == s
            line = ax.plot(lam[sel], amp[sel], "-", color=line[0].get_color() if line else None,
                           label=f"wave {w.attrs['wave']} (ND {w.attrs['nodal_diameter']})"
                           if s == segment[0] else None)
        color = line[0].get_color()
        ax.plot(lam[stable == 0], amp[stable == 0], "x", color=color, ms=4)
        ax.plot(lam[stable == 1], amp[stable == 1], "o", color=color, ms=3)
        if "cycles" in w:
            c = w["cycles"]
            verdict = c["stable"][()]
            for value, style in ((1, {"marker": "o"}), (0, {"marker": "o", "mfc": "none"}),
                                 (-1, {"marker": "s", "mfc": "none"})):
                pick = verdict == value
                ax.plot(c["lam"][()][pick], c["tip_amplitude"][()][pick] * 1e6, ls="none",
                        color=color, ms=8, **style)
    ax.axvline(1.0, color="0.5", lw=0.8, ls="--")
    ax.set_yscale("log")
    ax.set_xlabel("factor on the self-excitation (1 = configured mu)")
    ax.set_ylabel("tip amplitude, 0-peak [um]")
    ax.set_title(f"Limit-cycle branches, {label}\n(big markers: cycles at the configured mu; "
                 "o filled stable, o open unstable, square: not computed or uncertain;\n"
                 "small: o stable, x unstable)", fontsize=10)
    ax.legend(fontsize=8, ncol=2)
    save(fig, outdir, name, pdf, written)
    plt.close(fig)


def _damping(waves, label, plt, outdir, name, pdf, written) -> None:
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for w in waves:
        b = w["branch"]
        order = np.argsort(b["tip_amplitude"][()])
        ax.plot(b["tip_amplitude"][()][order] * 1e6, b["damping_ratio"][()][order] * 100, ".-",
                ms=3, label=f"wave {w.attrs['wave']} (ND {w.attrs['nodal_diameter']})")
    ax.set_xscale("log")
    ax.set_xlabel("tip amplitude, 0-peak [um]")
    ax.set_ylabel("friction + structural damping ratio [%]")
    ax.set_title(f"Amplitude-dependent damping of the nonlinear modes, {label}", fontsize=10)
    ax.legend(fontsize=8, ncol=2)
    save(fig, outdir, name, pdf, written)
    plt.close(fig)


def _amplitude_over_cases(g, angles, plt, outdir, pdf, written) -> None:
    """The smallest stable cycle's (else the smallest cycle's) tip amplitude per case."""
    settle = np.full(angles.shape[0], np.nan)
    stable_found = np.zeros(angles.shape[0], dtype=bool)
    band = np.full((angles.shape[0], 2), np.nan)  # the elastic law's friction band [m]
    for i in range(angles.shape[0]):
        case = g.get(f"case_{i}")
        for name in case if case is not None else []:
            if not name.startswith("wave_") or "cycles" not in case[name]:
                continue
            c = case[name]["cycles"]
            if "band" in c and np.isfinite(c["band"][:, 0]).any():
                band[i] = [np.nanmin(c["band"][:, 0]), np.nanmax(c["band"][:, 1])]
            amp, ok = c["tip_amplitude"][()], c["stable"][()] == 1
            pick = amp[ok] if ok.any() else amp
            if pick.size and not (stable_found[i] and not ok.any()):
                best = float(pick.min())
                if ok.any() and not stable_found[i]:
                    settle[i], stable_found[i] = best, True
                else:
                    settle[i] = np.nanmin([settle[i], best])
    fig, ax = plt.subplots(figsize=(7, 4))
    x, label = varying_key(g, angles)
    ax.plot(x, settle * 1e6, "o-", color="C3", mfc="none", label="unstable or not decided")
    ax.plot(x[stable_found], settle[stable_found] * 1e6, "o", color="C3", ms=8,
            label="stable")
    has = np.isfinite(band[:, 0])
    if has.any():  # every offset of the stuck contacts gives another exact orbit
        ax.vlines(x[has], band[has, 0] * 1e6, band[has, 1] * 1e6, color="C0", lw=4,
                  alpha=0.4, label="friction-limited band (the family's orbits)")
    ax.set_ylim(bottom=0)
    ax.set_xlabel(label)
    ax.set_ylabel("limit-cycle tip amplitude, 0-peak [um]")
    ax.set_title("Single-wave limit cycles at the configured intensity\n(where the flutter "
                 "settles only if stable: wheelrom settle)", fontsize=10)
    ax.legend(fontsize=8)
    save(fig, outdir, "limit_cycle_amplitude", pdf, written)
    plt.close(fig)


def varying_key(g, angles: np.ndarray) -> tuple[np.ndarray, str]:
    """``(values, label)`` of the study key that varies over the cases (the shroud angle when
    none does): a sweep records both contact angles, of which one is constant."""
    if "parameters" in g:
        values = g["parameters"][()]
        names = g["parameters"].attrs["names"].split(", ")
        for j, name in enumerate(names):
            column = values[:, j]
            if np.unique(column[np.isfinite(column)]).size > 1:
                return column, name
    if np.unique(angles[:, 0]).size > 1 and np.unique(angles[:, 1]).size == 1:
        return angles[:, 0], "tie-boss angle [deg]"
    return angles[:, 1], "shroud angle [deg]"
