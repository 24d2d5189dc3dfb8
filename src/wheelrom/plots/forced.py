"""Figures of a forced-response file (``wheelrom forced-response --out``, format
``wheelrom-forced-1``): the response curves of the configured and the tuned wheel, and the
blade tip amplitudes at the peaks (localisation)."""

from __future__ import annotations

import numpy as np

from wheelrom.plots.helpers import localisation_bars, need, save


def forced_figures(f, path: str, outdir: str, pdf: bool, written: list[str], plt) -> None:
    """``forced_response`` and ``forced_localisation`` into ``outdir``."""
    hz = need(f, "frequency_hz", path)  # (F,) [Hz]
    blades = need(f, "blade_amplitude", path)  # (F, N) [m]
    tuned = need(f, "tuned_blade_amplitude", path)
    attrs = f.attrs
    fig, ax = plt.subplots(figsize=(8, 4.5), layout="constrained")
    order = np.argsort(hz)
    ax.plot(hz[order], blades[order], color="tab:blue", lw=0.4, alpha=0.35)
    ax.plot(hz[order], blades[order].max(axis=1), color="tab:blue", lw=1.6,
            label="configured wheel: largest blade (thin: every blade)")
    ax.plot(hz[order], tuned[order].max(axis=1), "k--", lw=1.2, label="tuned wheel")
    for key, style, what in (("", "o", "peak"), ("tuned_", "s", "tuned peak")):
        if f"{key}peak_frequency_hz" in attrs:
            ax.plot(attrs[f"{key}peak_frequency_hz"], attrs[f"{key}peak_amplitude_m"], style,
                    mfc="none", color="tab:red",
                    label=f"{what} {attrs[f'{key}peak_amplitude_m']:.3g} m at "
                    f"{attrs[f'{key}peak_frequency_hz']:.6g} Hz")
    if "nonlinear" in f:  # the nonlinear steady response on the same grid (--nonlinear)
        g = f["nonlinear"]
        tip, ok = g["tip_amplitude"][()], g["converged"][()]
        law = g.attrs["law"]
        law = law.decode() if isinstance(law, bytes) else str(law)
        keep = order[ok[order]]
        ax.plot(hz[keep], tip[keep], "-", marker=".", color="tab:green", lw=1.6,
                label=f"nonlinear (contacts.law = '{law}', harmonic balance)")
        if "exact_curve" in g:  # --exact all: the exact states, stable and unstable
            e = g["exact_curve"]
            etip, stable, done = e["tip_amplitude_m"][()], e["stable"][()], e["converged"][()]
            for keep, style, what in ((done & stable, "o", "stable in every ND"),
                                      (done & ~stable, "x", "unstable")):
                if keep.any():
                    ax.plot(hz[keep], etip[keep], style, ms=5, mfc="none", color="tab:purple",
                            label=f"exact state (shooting), {what}")
        if "traced" in g:  # forced.continuation = "arclength": the points in order traced
            t = g["traced"]
            thz, ttip, growth = (t[k][()] for k in ("frequency_hz", "tip_amplitude_m",
                                                    "growth_per_s"))
            ax.plot(thz, ttip, "-", color="tab:olive", lw=1.0,
                    label=f"traced by arclength ({thz[np.isfinite(thz)].size} points)")
            grows = np.isfinite(growth) & (growth > 0)
            if grows.any():
                ax.plot(thz[grows], ttip[grows], "x", ms=4, color="tab:olive",
                        label="traced, unstable (Hill's method)")
            for fold in t["folds_hz"][()]:
                ax.axvline(fold, color="tab:olive", lw=0.6, ls=":")
    ax.set(xlabel="excitation frequency [Hz]", ylabel="blade tip amplitude [m]", yscale="log")
    factor = attrs.get("amplification_factor")
    ax.set_title("Forced response to the nozzle (engine order "
                 f"{attrs.get('stator_vanes', '?')})"
                 + (f": amplification {factor:.3g}" if factor is not None else ""))
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    save(fig, outdir, "forced_response", pdf, written)
    plt.close(fig)
    if "peak_blade_amplitude" in f and "tuned_peak_blade_amplitude" in f:
        peak, tuned_peak = f["peak_blade_amplitude"][()], f["tuned_peak_blade_amplitude"][()]
        fig, ax = plt.subplots(figsize=(max(7, 0.14 * peak.size), 4.2), layout="constrained")
        localisation_bars(ax, peak, tuned_peak,
                          f"configured, at {attrs.get('peak_frequency_hz', np.nan):.6g} Hz",
                          f"tuned, at {attrs.get('tuned_peak_frequency_hz', np.nan):.6g} Hz")
        ax.set_title("Blade tip amplitudes at the peaks (localisation)")
        save(fig, outdir, "forced_localisation", pdf, written)
        plt.close(fig)
