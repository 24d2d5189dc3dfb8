"""Figures of a settle file (``wheelrom settle --out``): per case the amplitude envelope over
time with the stationarity windows marked, the ND energy of the settled state and the blade
amplitudes around the wheel; over the cases the settled amplitude and how it settled."""

from __future__ import annotations

import textwrap

import numpy as np

from wheelrom.plots.helpers import save
from wheelrom.plots.limit_cycle import varying_key


def settle_figures(f, path: str, outdir: str, pdf: bool, written: list[str], plt) -> None:
    g = f["settle"]
    angles = g["angles_deg"][()]
    tolerance = float(g.attrs["tolerance"])
    for i in range(angles.shape[0]):
        case = g[f"case_{i}"]
        if "window_end" not in case or case["window_end"].size == 0:
            continue
        label = f"tie-boss {angles[i, 0]:g} deg, shroud {angles[i, 1]:g} deg"
        _case(case, label, tolerance, plt, outdir, f"settle_case{i}", pdf, written)
    if angles.shape[0] > 1:
        _summary(g, angles, plt, outdir, pdf, written)


def _case(case, label, tolerance, plt, outdir, name, pdf, written) -> None:
    fig, (ax, bx, cx) = plt.subplots(1, 3, figsize=(14, 4.2),
                                     gridspec_kw={"width_ratios": [2, 1.2, 1.2]})
    end = case["window_end"][()]
    A = case["window_amplitude"][()] * 1e6
    change = case["window_change"][()]
    ax.fill_between(end, A.min(axis=1), A.max(axis=1), color="C0", alpha=0.25,
                    label="blades: min .. max", step="pre")
    ax.step(end, A.max(axis=1), "C0", where="pre", label="largest blade")
    ax.step(end, A.mean(axis=1), "C0--", where="pre", lw=0.8, label="mean")
    # the first window has nothing before it to change against (its row is NaN): never green
    quiet = 1 + np.flatnonzero(change[1:].max(axis=1) <= tolerance)
    for k in quiet:
        ax.axvspan(end[k - 1], end[k], color="C2", alpha=0.15, lw=0)
    ax.set_xlabel("simulated time [s]")
    ax.set_ylabel("tip amplitude per window [um]")
    verdict = textwrap.fill(case.attrs["verdict"], 95)
    ax.set_xlim(left=0.0)
    ax.set_title(f"{label}\n{verdict}", fontsize=8)
    ax.legend(fontsize=7, title="green: windows stationary", title_fontsize=7)
    if "nd_energy" in case:
        e = case["nd_energy"][()]
        bx.bar(np.arange(e.size), e * 100, color="C1")
        bx.set_xlabel("nodal diameter")
        bx.set_ylabel("share of the tip motion's energy [%]")
        bx.set_title("ND content, last window", fontsize=9)
        a = case["amplitude"][()] * 1e6
        cx.bar(np.arange(a.size), a, color="C0")
        cx.set_xlabel("blade")
        cx.set_ylabel("tip amplitude [um]")
        cx.set_title("around the wheel, last window", fontsize=9)
    fig.tight_layout()
    save(fig, outdir, name, pdf, written)
    plt.close(fig)


def _summary(g, angles, plt, outdir, pdf, written) -> None:
    x, label = varying_key(g, angles)
    kinds = [k.decode() for k in g["kind"][()]]
    amp = g["max_amplitude"][()] * 1e6
    settled = g["settled"][()].astype(bool)
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(x, amp, "-", color="C0", lw=0.8)
    for kind, marker in (("periodic", "o"), ("quasi-periodic", "s"), ("chaotic", "^")):
        pick = settled & np.array([k == kind for k in kinds])
        ax.plot(x[pick], amp[pick], marker, color="C0", ms=7, label=f"settled, {kind}")
    low, high = np.full(x.size, np.nan), np.full(x.size, np.nan)
    if "band" in g:  # the range over the last bounded_span, the trend's
        low, high = g["band"][:, 0] * 1e6, g["band"][:, 1] * 1e6
    else:  # older files: the run's second half
        for i in range(x.size):
            windows = g[f"case_{i}"].get("window_amplitude")
            if windows is not None and windows.shape[0] >= 2:
                top = windows[()].max(axis=1)[windows.shape[0] // 2 :] * 1e6
                low[i], high[i] = top.min(), top.max()
    bounded = g["bounded"][()].astype(bool) if "bounded" in g else np.zeros(x.size, bool)
    pick = ~settled & np.isfinite(low)
    ax.vlines(x[pick & bounded], low[pick & bounded], high[pick & bounded], color="C2", lw=3,
              alpha=0.5, label="bounded: range over the last span")
    ax.plot(x[~settled], amp[~settled], "x", color="C3", ms=8, label="not settled (last window)")
    rest = pick & ~bounded
    ax.vlines(x[rest], low[rest], high[rest], color="C3", lw=3, alpha=0.4,
              label="not bounded at settle.max_time: range over the last span")
    if "still_growing" in g:  # a range taken while the motion still grows is a lower bound
        rising = pick & g["still_growing"][()].astype(bool)
        ax.plot(x[rising], high[rising], linestyle="none", marker=r"$\uparrow$", color="C3", ms=14,
                label="... still growing at the end (its trend)")
    if "start_amplitude" in g:
        ax.plot(x, g["start_amplitude"][()] * 1e6, "d--", color="0.5", ms=5, lw=0.8,
                label="single-wave exact orbit (the start)")
    ax.margins(y=0.1)  # room for the arrows above the highest range
    ax.set_ylim(bottom=0)
    ax.set_xlabel(label)
    ax.set_ylabel("largest blade's tip amplitude [um]")
    ax.set_title("Where the flutter settles (whole wheel, every ND free)", fontsize=10)
    ax.legend(fontsize=8)
    save(fig, outdir, "settle_amplitude", pdf, written)
    plt.close(fig)
