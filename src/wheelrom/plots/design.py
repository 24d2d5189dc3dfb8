"""Figures of a study with the nonlinear forced response (``wheelrom study
--forced-nonlinear``): the friction damper's design curve (the refined peak tip amplitude
against the first varied key, one line per value of a second; the smallest marked) and every
case's response curve with its peak."""

from __future__ import annotations

import numpy as np

from wheelrom.config.study import short_name
from wheelrom.plots.helpers import need, save
from wheelrom.results.study_layout import design_summary, read_parameters


def design_figures(f, path: str, outdir: str, pdf: bool, written: list[str], plt) -> None:
    """``design_curve`` and ``design_response_curves`` into ``outdir``."""
    g = f["forced_nonlinear"]
    peak = need(f, "forced_nonlinear/peak_amplitude", path)
    peak_hz = need(f, "forced_nonlinear/peak_frequency_hz", path)
    p = read_parameters(f)
    shape = [int(n) for n in p["shape"]]
    axes = [a for a, n in enumerate(shape) if n > 1] or [0]
    # the x axis: the first varied key with numbers (a preload), the others one line each
    numbers = [a for a in axes if np.isfinite(np.asarray(
        p["values"][:, list(p["axis"]).index(a)], dtype=float)).all()]
    first = (numbers or axes)[0]
    j = list(p["axis"]).index(first)
    grid = np.indices(shape).reshape(len(shape), -1)
    x = np.asarray(p["values"][:, j], dtype=float)
    numeric = np.isfinite(x).all()
    if not numeric:
        x = grid[first].astype(float)
    law = g.attrs["law"]
    law = law.decode() if isinstance(law, bytes) else str(law)
    summary = design_summary(f)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True, layout="constrained")
    others = [a for a in axes if a != first]
    groups = [np.flatnonzero(grid[others[0]] == k) for k in range(shape[others[0]])] \
        if others else [np.arange(peak.size)]
    for rows in groups:
        rows = rows[np.argsort(x[rows])]
        label = None
        if others:
            k = list(p["axis"]).index(others[0])
            label = f"{short_name(p['names'][k])} = {p['text'][rows[0]][k]}"
        line, = top.plot(x[rows], peak[rows] * 1e6, "o-", label=label)
        bottom.plot(x[rows], peak_hz[rows], "o-", label=label)
        if "exact_tip_amplitude" in g:  # forced.exact: the exact state, stable or not
            exact = g["exact_tip_amplitude"][()][rows] * 1e6
            stable = _stable(summary)[rows]
            for marker, which in (("s", stable), ("x", ~stable)):
                top.plot(x[rows][which], exact[which], marker, ms=6, mfc="none",
                         color=line.get_color())
    best = summary["optimum"]
    if best is not None:
        top.plot(x[best], peak[best] * 1e6, "*", ms=14, color="tab:red",
                 label=f"smallest: {peak[best] * 1e6:.3g} um at {peak_hz[best]:.5g} Hz")
    span = x[np.isfinite(x) & (x > 0)]
    if numeric and span.size == x.size and span.max() > 20 * span.min():
        top.set_xscale("log")
    top.set(ylabel="peak tip amplitude [um]", yscale="log")
    bottom.set(ylabel="peak frequency [Hz]", xlabel=short_name(p["names"][j]))
    if not numeric:
        bottom.set_xticks(x, [t[j] for t in p["text"]])
    top.set_title(f"Friction damper design curve: nozzle resonance with friction "
                  f"(contacts.law = '{law}', H = {int(g.attrs['harmonics'])}; lines the "
                  f"balance, squares / x the exact states, stable / unstable)", fontsize=9)
    for ax in (top, bottom):
        ax.grid(alpha=0.3)
    top.legend(fontsize=7)
    save(fig, outdir, "design_curve", pdf, written)
    plt.close(fig)
    _response_curves(g, p, peak, peak_hz, outdir, pdf, written, plt)


def _response_curves(g, p: dict, peak: np.ndarray, peak_hz: np.ndarray, outdir: str,
                     pdf: bool, written: list[str], plt) -> None:
    """``design_response_curves``: every case's curve with its refined peak and, where
    traced, its unstable points."""
    hz, tip = g["frequency_hz"][()], g["tip_amplitude"][()]
    ok = g["converged"][()]
    fig, ax = plt.subplots(figsize=(8, 4.5), layout="constrained")
    for c in range(peak.size):
        # a traced curve's points in the order traced (its folds turn back); a row Newton
        # missed, or the gap between two traced pieces, breaks the line
        line, = ax.plot(np.where(ok[c], hz[c], np.nan), np.where(ok[c], tip[c], np.nan) * 1e6,
                        ".-", lw=1.0,
                        label=", ".join(t.decode() if isinstance(t, bytes) else str(t)
                                        for t in p["text"][c]))
        if np.isfinite(peak[c]):
            ax.plot(peak_hz[c], peak[c] * 1e6, "o", mfc="none", color=line.get_color())
        if "growth" in g:  # a traced curve's unstable points (Hill's method)
            grows = ok[c] & (g["growth"][c] > 0)
            ax.plot(hz[c][grows], tip[c][grows] * 1e6, "x", ms=4, color=line.get_color())
    ax.set(xlabel="excitation frequency [Hz]", ylabel="blade tip amplitude [um]", yscale="log",
           title="Nonlinear forced response per case (circles: refined peaks; x: unstable)")
    ax.grid(alpha=0.3)
    if peak.size <= 12:
        ax.legend(fontsize=7)
    save(fig, outdir, "design_response_curves", pdf, written)
    plt.close(fig)


def _stable(summary: dict) -> np.ndarray:
    """``(C,)`` bool: the design summary's exact states that are stable (False where none
    was computed: no square is drawn without a state)."""
    return np.array([s is True for s in summary["exact_stable"]], dtype=bool)
