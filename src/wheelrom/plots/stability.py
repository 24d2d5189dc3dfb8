"""Stability figures from ``/stability`` (``wheelrom stability --out``): the stability map
(shroud angle x nodal diameter, colour = growth rate of the ND's fastest mode, zero contour),
the root locus across angles (frequency vs growth rate), the verdict per angle and, from
``stability --margin``, the flutter margin per angle.

Grids with several tie-boss angles show the first one (the title says which).
"""

from __future__ import annotations

import numpy as np

from wheelrom.plots.helpers import cell_edges as _cell_edges
from wheelrom.plots.helpers import need as _need
from wheelrom.plots.helpers import save as _save
from wheelrom.results.layout import read_config


def stability_figures(f, path: str, outdir: str, pdf: bool, written: list[str], plt) -> None:
    """Write ``stability_map``, ``root_locus`` and ``stability_verdict`` (first tie-boss
    angle) and, for a grid of several tie-boss and shroud angles, ``stability_map_2d``."""
    angles = _need(f, "stability/angles_deg", path)
    if len(np.unique(angles[:, 0])) > 1 and len(np.unique(angles[:, 1])) > 1:
        fig = _map_2d(angles, _need(f, "stability/max_growth_rate", path), plt)
        _save(fig, outdir, "stability_map_2d", pdf, written)
        plt.close(fig)
    rows = angles[:, 0] == angles[0, 0]
    data = {
        "shroud": angles[rows, 1],
        "nd": _need(f, "stability/nodal_diameter", path)[rows],
        "growth": _need(f, "stability/growth_rate", path)[rows],
        "hz": _need(f, "stability/frequency_hz", path)[rows],
        "tieboss": angles[0, 0],
    }
    order = np.argsort(data["shroud"])
    data = {k: (v[order] if isinstance(v, np.ndarray) else v) for k, v in data.items()}
    figures = [("stability_map", _map), ("root_locus", _root_locus),
               ("stability_verdict", _verdict)]
    if "stability/margin_ratio" in f:  # stability --margin
        for name in ("margin_ratio", "margin_nodal_diameter", "margin_frequency_hz"):
            data[name] = f[f"stability/{name}"][()][rows][order]
        flutter = read_config(f, path).flutter
        data["mu"] = flutter.table_scale if flutter.model == "table" else flutter.mu
        data["table"] = flutter.model == "table"
        figures.append(("flutter_margin", _margin))
    for name, draw in figures:
        fig = draw(data, plt)
        _save(fig, outdir, name, pdf, written)
        plt.close(fig)


def _per_nd_max(data) -> np.ndarray:
    """``(cases, N/2 + 1)`` largest growth rate per nodal diameter [1/s]."""
    nds = int(data["nd"].max()) + 1
    out = np.full((data["nd"].shape[0], nds), -np.inf)
    for c in range(out.shape[0]):
        np.maximum.at(out[c], data["nd"][c], data["growth"][c])
    return out


def _map(data, plt):
    from matplotlib import colors

    rates = _per_nd_max(data)
    fig, ax = plt.subplots(figsize=(8, 5))
    limit = max(np.abs(rates[np.isfinite(rates)]).max(), 1e-9)
    x = _cell_edges(data["shroud"], 2.5)
    y = np.arange(rates.shape[1] + 1) - 0.5
    norm = colors.TwoSlopeNorm(vcenter=0.0, vmin=-limit, vmax=limit)
    mesh = ax.pcolormesh(x, y, rates.T, cmap="RdBu_r", norm=norm)
    if rates.shape[0] > 1 and (rates > 0).any() and (rates < 0).any():
        ax.contour(data["shroud"], np.arange(rates.shape[1]), rates.T, levels=[0.0],
                   colors="k", linewidths=1.2)
    fig.colorbar(mesh, ax=ax, label="largest growth rate [1/s] (> 0: unstable)")
    ax.set_xlabel("shroud angle [deg]")
    ax.set_ylabel("nodal diameter")
    ax.set_title(f"Linear stability per nodal diameter (tie-boss {data['tieboss']:g} deg)")
    return fig


def _root_locus(data, plt):
    from matplotlib import cm, colors

    fig, ax = plt.subplots(figsize=(8, 5))
    norm = colors.Normalize(vmin=data["shroud"].min(), vmax=max(data["shroud"].max(), 1e-9))
    top = max(1, data["growth"].shape[1] // 10)  # the fastest tenth of every case's modes
    for c, angle in enumerate(data["shroud"]):
        ax.scatter(data["growth"][c, :top], data["hz"][c, :top], s=10,
                   color=cm.viridis(norm(angle)))
    ax.axvline(0.0, color="k", lw=0.8)
    fig.colorbar(cm.ScalarMappable(norm=norm, cmap="viridis"), ax=ax, label="shroud angle [deg]")
    ax.set_xlabel("growth rate [1/s]")
    ax.set_ylabel("frequency [Hz]")
    ax.set_yscale("log")
    ax.set_title("Root locus across angles: the fastest-growing modes")
    return fig


def _verdict(data, plt):
    fig, ax = plt.subplots(figsize=(8, 4.5))
    i = np.argmax(data["growth"], axis=1)
    rows = np.arange(len(i))
    rate, nd, hz = data["growth"][rows, i], data["nd"][rows, i], data["hz"][rows, i]
    ax.plot(data["shroud"], rate, "-", color="0.6")
    unstable = rate > 1e-6
    for mask, colour, label in ((unstable, "tab:red", "unstable"),
                                (~unstable, "tab:blue", "stable")):
        ax.scatter(data["shroud"][mask], rate[mask], color=colour, label=label, zorder=3)
    for x, y, k, f in zip(data["shroud"], rate, nd, hz, strict=True):
        ax.annotate(f"ND {k}\n{f:.0f} Hz", (x, y), textcoords="offset points", xytext=(0, 6),
                    ha="center", fontsize=7)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel("shroud angle [deg]")
    ax.set_ylabel("largest growth rate [1/s]")
    ax.set_title(f"Verdict per angle (tie-boss {data['tieboss']:g} deg): fastest mode")
    ax.legend()
    return fig


def _margin(data, plt):
    """Critical Van der Pol intensity over the configured one per angle (log scale): above 1
    the case is stable at the configured mu, and the ratio says how much stronger the
    self-excitation may get before the contacts stop holding it down."""
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ratio = np.asarray(data["margin_ratio"], float)
    top = np.nanmax(ratio[np.isfinite(ratio)], initial=1.0) * 2
    shown = np.where(np.isfinite(ratio), ratio, top)
    ax.plot(data["shroud"], shown, "-", color="0.6")
    stable = shown > 1.0
    at = "the configured factor" if data.get("table") else "the configured mu"
    for mask, colour, label in ((stable, "tab:blue", f"stable at {at}"),
                                (~stable, "tab:red", f"unstable at {at}")):
        ax.scatter(data["shroud"][mask], shown[mask], color=colour, label=label, zorder=3)
    for x, y, k, hz in zip(data["shroud"], shown, data["margin_nodal_diameter"],
                           data["margin_frequency_hz"], strict=True):
        if np.isfinite(hz):
            ax.annotate(f"ND {k}\n{hz:.0f} Hz", (x, y), textcoords="offset points",
                        xytext=(0, 6), ha="center", fontsize=7)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_yscale("log")
    ax.set_xlabel("shroud angle [deg]")
    if data.get("table"):
        ax.set_ylabel(f"critical / configured factor on the aerodynamic table ({data['mu']:g})")
    else:
        ax.set_ylabel(f"critical mu / configured mu ({data['mu']:g} N s/m)")
    ax.set_title(f"Flutter margin per angle (tie-boss {data['tieboss']:g} deg): the mode that "
                 "crosses first")
    ax.legend()
    return fig


def _map_2d(angles: np.ndarray, rate: np.ndarray, plt):
    """Largest growth rate [1/s] over tie-boss x shroud angle, zero contour (the stability
    boundary); grid points without a case are blank."""
    from matplotlib import colors

    tieboss, shroud = np.unique(angles[:, 0]), np.unique(angles[:, 1])
    grid = np.full((tieboss.size, shroud.size), np.nan)
    grid[np.searchsorted(tieboss, angles[:, 0]), np.searchsorted(shroud, angles[:, 1])] = rate
    limit = max(np.nanmax(np.abs(grid)), 1e-9)
    fig, ax = plt.subplots(figsize=(7.5, 6))
    norm = colors.TwoSlopeNorm(vcenter=0.0, vmin=-limit, vmax=limit)
    mesh = ax.pcolormesh(_cell_edges(shroud, 2.5), _cell_edges(tieboss, 2.5), grid,
                         cmap="RdBu_r", norm=norm)
    if (grid > 0).any() and (grid < 0).any():
        ax.contour(shroud, tieboss, grid, levels=[0.0], colors="k", linewidths=1.2)
    fig.colorbar(mesh, ax=ax, label="largest growth rate [1/s] (> 0: unstable)")
    ax.set_xlabel("shroud angle [deg]")
    ax.set_ylabel("tie-boss angle [deg]")
    ax.set_title("Linear stability over both contact angles")
    return fig
