"""Figures of a Monte Carlo mistuning study (a study file with ``/forced``, ``wheelrom study
--forced``): the distribution of the amplification factor (histogram and empirical CDF, the
95th percentile and Whitehead's bound marked), the distribution of the largest linear growth
rate, and the blade amplitudes at the peak of the worst realisation against the tuned
wheel's (localisation)."""

from __future__ import annotations

import numpy as np

from wheelrom.plots.helpers import localisation_bars, need, save
from wheelrom.results.study_layout import distribution, stable_amplification


def montecarlo_figures(f, path: str, outdir: str, pdf: bool, written: list[str], plt) -> None:
    """Write ``mc_amplification``, ``mc_growth_rate`` and ``mc_localisation`` into
    ``outdir`` (nothing for a study without ``/forced``)."""
    if "forced" not in f:
        return
    need(f, "forced/amplification", path)
    amplification = stable_amplification(f)[0]  # an unstable case's factor means nothing
    bound = float(f["forced"].attrs["whitehead_bound"])
    for name, fig in (("mc_amplification", _amplification(amplification, bound, plt)),
                      ("mc_growth_rate", _growth(need(f, "stability/max_growth_rate", path),
                                                 plt)),
                      ("mc_localisation", _localisation(f, path, amplification, plt))):
        if fig is not None:
            save(fig, outdir, name, pdf, written)
            plt.close(fig)


def _amplification(values: np.ndarray, bound: float, plt):
    """Histogram and empirical CDF of the amplification factor."""
    x = np.sort(values[np.isfinite(values)])
    if not x.size:
        return None
    d = distribution(x)
    fig, (hist, cdf) = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    hist.hist(x, bins=max(5, min(40, int(np.sqrt(x.size)) * 2)), color="tab:blue", alpha=0.8)
    hist.set_xlabel("amplification factor (peak max-blade amplitude / tuned)")
    hist.set_ylabel("realisations")
    cdf.step(x, np.arange(1, x.size + 1) / x.size, where="post", color="tab:blue")
    cdf.set_xlabel("amplification factor")
    cdf.set_ylabel("empirical CDF")
    cdf.set_ylim(0, 1.02)
    for ax in (hist, cdf):
        ax.axvline(d["p95"], color="tab:orange", ls="--", label=f"95th percentile {d['p95']:.3g}")
        ax.axvline(bound, color="k", ls=":", label=f"Whitehead (1 + sqrt N) / 2 = {bound:.3g}")
        ax.axvline(1.0, color="0.6", lw=0.8)
        ax.grid(alpha=0.3)
    hist.legend(fontsize=8)
    fig.suptitle(f"Forced-response amplification over {x.size} realisations: mean "
                 f"{d['mean']:.3g}, max {d['max']:.3g}")
    return fig


def _growth(values: np.ndarray, plt):
    """Histogram of every realisation's largest linear growth rate."""
    x = values[np.isfinite(values)]
    if not x.size:
        return None
    d = distribution(x)
    fig, ax = plt.subplots(figsize=(7, 4.2), layout="constrained")
    ax.hist(x, bins=max(5, min(40, int(np.sqrt(x.size)) * 2)), color="tab:red", alpha=0.8)
    ax.axvline(0.0, color="k", lw=0.8)
    ax.axvline(d["p95"], color="tab:orange", ls="--", label=f"95th percentile {d['p95']:.3g} /s")
    ax.set_xlabel("largest linear growth rate [1/s] (> 0: unstable)")
    ax.set_ylabel("realisations")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax.set_title(f"Flutter over {x.size} realisations: {int((x > 1e-6).sum())} unstable")
    return fig


def _localisation(f, path: str, amplification: np.ndarray, plt):
    """The worst realisation's blade tip amplitudes at its peak, the tuned wheel's at its."""
    if not np.isfinite(amplification).any():
        return None
    c = int(np.nanargmax(amplification))
    blades = need(f, "forced/blade_amplitude", path)[c]
    tuned = need(f, "forced/tuned_blade_amplitude", path)[c]
    fig, ax = plt.subplots(figsize=(max(7, 0.14 * blades.size), 4.2), layout="constrained")
    localisation_bars(ax, blades, tuned, f"case {c} at {f['forced/peak_frequency_hz'][c]:.6g} Hz",
                      f"tuned at {f['forced/tuned_peak_frequency_hz'][c]:.6g} Hz")
    ax.set_title(f"Worst realisation: amplification {amplification[c]:.3g} (localisation)")
    return fig
