"""Figures of a design study (format ``wheelrom-sweep-2``): per case the largest linear growth
rate (zero contour: the stability boundary), the final transient amplitude, the smallest
normal force and the fraction of open contacts per kind, with the transient-confirmed cases
marked.

Two varied axes: one map per quantity. One axis: the quantities against it. More: one map per
pair of axes, the other axes at their first value (the title says so). A named choice
(``segment.preset``) is an axis of its values in order; zipped keys are labelled by the first.
"""

from __future__ import annotations

import itertools

import numpy as np

from wheelrom.config import CONTACT_KINDS
from wheelrom.config.study import short_name
from wheelrom.plots.helpers import cell_edges, need, save
from wheelrom.results.study_layout import read_parameters


class StudyData:
    """Per-case quantities ``(C,)`` of a study file and its axes: ``shape``, ``axes`` (the
    varied ones, length > 1), per axis ``label``, ``coords`` (numbers for the map) and
    ``ticks`` (text of non-numeric or unordered values, else None)."""

    def __init__(self, f, path: str):
        p = read_parameters(f)
        self.shape = p["shape"]
        self.axes = [a for a, n in enumerate(self.shape) if n > 1]
        grid = np.indices(self.shape).reshape(len(self.shape), -1)  # (axes, C) indices
        self.label, self.coords, self.ticks = {}, {}, {}
        for a in range(len(self.shape)):
            keys = [j for j, ax in enumerate(p["axis"]) if ax == a]
            j = keys[0]
            rows = [int(np.flatnonzero(grid[a] == k)[0]) for k in range(self.shape[a])]
            values = p["values"][rows, j]
            together = f" (with {', '.join(short_name(p['names'][k]) for k in keys[1:])})"
            self.label[a] = short_name(p["names"][j]) + (together if len(keys) > 1 else "")
            ordered = np.isfinite(values).all() and (np.diff(values) > 0).all()
            self.coords[a] = values if ordered else np.arange(self.shape[a], dtype=float)
            self.ticks[a] = None if ordered else [p["text"][r][j] for r in rows]
        self.growth = need(f, "stability/max_growth_rate", path)
        self.status = [s.decode().partition(":")[0] for s in need(f, "cases/status", path)]
        self.quantities = {"growth_rate": self.growth}
        if "forced/amplification" in f:  # study --forced: the factor over the varied keys
            self.quantities["amplification"] = f["forced/amplification"][()]
        self.transient = "cases/max_tip_amplitude" in f and "done" in self.status
        if self.transient:
            self._transient_quantities(f, path)
        else:  # no transient: the static equilibrium's normal force
            force = need(f, "stability/normal_force", path)  # (C, K, N)
            for k, kind in enumerate(CONTACT_KINDS):
                if np.isfinite(force[:, k]).any():
                    self.quantities[f"min_normal_force_{kind}"] = _nanmin(force[:, k], axis=1)

    def _transient_quantities(self, f, path: str) -> None:
        amp = need(f, "cases/max_tip_amplitude", path)
        self.quantities["final_amplitude"] = np.array([_last(a) for a in amp])
        for kind in CONTACT_KINDS:
            if f"cases/min_normal_force/{kind}" in f:
                force = f[f"cases/min_normal_force/{kind}"][()]
                if np.isfinite(force).any():
                    self.quantities[f"min_normal_force_{kind}"] = _nanmin(force, axis=1)
                    opened = f[f"cases/open_fraction/{kind}"][()]
                    self.quantities[f"open_fraction_{kind}"] = np.array([_last(o) for o in opened])


def _nanmin(a: np.ndarray, axis: int) -> np.ndarray:
    finite = np.isfinite(a).any(axis=axis)
    out = np.full(finite.shape, np.nan)
    out[finite] = np.nanmin(a[finite], axis=axis)
    return out


def _last(values: np.ndarray) -> float:
    """The last finite window value (NaN: none)."""
    finite = values[np.isfinite(values)]
    return float(finite[-1]) if finite.size else np.nan


WHAT = {
    "growth_rate": ("largest linear growth rate [1/s] (> 0: unstable)", "RdBu_r"),
    "final_amplitude": ("final max tip amplitude [m] (transient)", "magma"),
    "min_normal_force": ("smallest normal force [N]", "viridis"),
    "open_fraction": ("fraction of contacts open, last window", "cividis"),
    "amplification": ("forced-response amplification factor (peak / tuned peak)", "plasma"),
}


def _what(name: str) -> tuple[str, str]:
    for prefix, (label, cmap) in WHAT.items():
        if name.startswith(prefix):
            kind = name.removeprefix(prefix).strip("_")
            return (f"{kind} {label}" if kind else label), cmap
    raise KeyError(name)  # pragma: no cover


def study_figures(f, path: str, outdir: str, pdf: bool, written: list[str], plt) -> None:
    """Write the study's figures (module docstring) into ``outdir``."""
    d = StudyData(f, path)
    if "forced_nonlinear" in f:  # study --forced-nonlinear: the damper's design curve
        from wheelrom.plots.design import design_figures

        design_figures(f, path, outdir, pdf, written, plt)
    if len(d.axes) == 1:
        fig = _lines(d, d.axes[0], plt)
        save(fig, outdir, "study_1d", pdf, written)
        plt.close(fig)
        return
    pairs = list(itertools.combinations(d.axes, 2))
    for a, b in pairs:
        suffix = "" if len(pairs) == 1 else f"_{a}_{b}"
        for name, values in d.quantities.items():
            fig = _map(d, a, b, name, values, plt)
            save(fig, outdir, f"study_{name}{suffix}", pdf, written)
            plt.close(fig)


def _slice(d: StudyData, a: int, b: int, values: np.ndarray) -> tuple[np.ndarray, str]:
    """``(shape[a], shape[b])`` of ``values`` with every other axis at its first value, and
    the words that say so (empty when there are no other axes)."""
    full = np.asarray(values, dtype=float).reshape(d.shape)
    index = tuple(slice(None) if k in (a, b) else 0 for k in range(len(d.shape)))
    others = [k for k in d.axes if k not in (a, b)]
    note = ", ".join(f"{d.label[k]} = {_tick(d, k, 0)}" for k in others)
    return full[index], (f" at {note}" if note else "")


def _tick(d: StudyData, axis: int, k: int) -> str:
    return d.ticks[axis][k] if d.ticks[axis] else f"{d.coords[axis][k]:g}"


def _map(d: StudyData, a: int, b: int, name: str, values: np.ndarray, plt):
    """One quantity over axes ``a`` (y) x ``b`` (x); blank: not computed; markers: cases whose
    transient ran (o) or failed (x)."""
    from matplotlib import colors

    grid, note = _slice(d, a, b, values)
    done, _ = _slice(d, a, b, np.array([s == "done" for s in d.status], dtype=float))
    failed, _ = _slice(d, a, b, np.array([s == "failed" for s in d.status], dtype=float))
    label, cmap = _what(name)
    x, y = d.coords[b], d.coords[a]
    fig, ax = plt.subplots(figsize=(7.5, 6))
    finite = grid[np.isfinite(grid)]
    norm = None
    if name == "growth_rate" and finite.size:
        # symmetric log: slightly damped cases (-0.1 /s next to +20 /s) stay visibly blue
        limit = max(np.abs(finite).max(), 1e-9)
        norm = colors.SymLogNorm(linthresh=1e-3 * limit, vmin=-limit, vmax=limit)
    elif name == "final_amplitude" and (finite > 0).any():
        positive = finite[finite > 0]
        norm = colors.LogNorm(vmin=positive.min(), vmax=max(positive.max(), positive.min() * 10))
    mesh = ax.pcolormesh(_edges(x), _edges(y), np.ma.masked_invalid(grid), cmap=cmap, norm=norm)
    for which, centres in (("x", x), ("y", y)):  # an axis of decades: logarithmic
        if _decades(centres):
            getattr(ax, f"set_{which}scale")("log")
    scale = "; symmetric log scale" if name == "growth_rate" else ""
    fig.colorbar(mesh, ax=ax, label=label.replace(")", f"{scale})") if scale else label)
    if name == "growth_rate" and (grid > 0).any() and (grid < 0).any() and min(grid.shape) > 1:
        ax.contour(x, y, grid, levels=[0.0], colors="k", linewidths=1.2)
    yy, xx = np.meshgrid(y, x, indexing="ij")
    # white rings with a black halo: visible on dark and light cells alike
    ax.scatter(xx[done > 0], yy[done > 0], s=30, facecolors="none", edgecolors="k",
               linewidths=2.4, label="transient done")
    ax.scatter(xx[done > 0], yy[done > 0], s=30, facecolors="none", edgecolors="w",
               linewidths=1.0)
    if (failed > 0).any():
        ax.scatter(xx[failed > 0], yy[failed > 0], s=28, marker="x", color="k",
                   label="transient failed")
    if (done > 0).any() or (failed > 0).any():
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, fontsize=8)
    _axis_labels(ax, d, b, "x")
    _axis_labels(ax, d, a, "y")
    boundary = " (black line: zero, the stability boundary)" if name == "growth_rate" else ""
    ax.set_title(f"{label.split(' [')[0]}{note}{boundary}", fontsize=10)
    return fig


def _decades(centres: np.ndarray) -> bool:
    """An axis whose values are positive and span more than a decade, spaced more evenly in
    their logarithm than linearly (a micro-slip velocity 0.006..6 m/s): drawn on a log axis."""
    c = np.asarray(centres, dtype=float)
    if c.size < 3 or not np.all(np.isfinite(c)) or c.min() <= 0 or c.max() < 10 * c.min():
        return False
    linear, logarithmic = np.diff(c), np.diff(np.log(c))
    return np.ptp(logarithmic) / logarithmic.mean() < np.ptp(linear) / linear.mean()


def _edges(centres: np.ndarray) -> np.ndarray:
    if _decades(centres):  # cells centred in the logarithm
        return np.exp(cell_edges(np.log(centres), 0.5))
    half = 0.5 if centres.size == 1 else 0.5 * float(np.min(np.diff(centres)))
    return cell_edges(centres, half)


def _axis_labels(ax, d: StudyData, axis: int, which: str) -> None:
    getattr(ax, f"set_{which}label")(d.label[axis])
    if d.ticks[axis]:
        getattr(ax, f"set_{which}ticks")(d.coords[axis], d.ticks[axis])


def _lines(d: StudyData, a: int, plt):
    """One varied axis: every quantity against it; filled markers: transient done."""
    names = list(d.quantities)
    fig, axes = plt.subplots(len(names), 1, figsize=(8, 2.6 * len(names)), sharex=True,
                             layout="constrained", squeeze=False)
    x = d.coords[a]
    done = np.array([s == "done" for s in d.status])
    for ax, name in zip(axes[:, 0], names, strict=True):
        y = np.asarray(d.quantities[name], dtype=float).reshape(-1)
        ax.plot(x, y, "-", color="0.6")
        if name == "growth_rate":
            ax.axhline(0.0, color="k", lw=0.8)
            unstable = y > 1e-6
            ax.scatter(x[unstable], y[unstable], color="tab:red", label="unstable", zorder=3)
            ax.scatter(x[~unstable], y[~unstable], color="tab:blue", label="stable", zorder=3)
        else:
            ax.scatter(x[done], y[done], color="k", s=16, zorder=3, label="transient done")
        if name == "final_amplitude" and (y[np.isfinite(y)] > 0).all() and done.any():
            ax.set_yscale("log")
        ax.set_ylabel(_what(name)[0], fontsize=8)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    _axis_labels(axes[-1, 0], d, a, "x")
    axes[0, 0].set_title(f"Study over {d.label[a]}")
    return fig
