"""Figures and tables of docs/results.md "Mistuning" from the study files of
run/study_mistuning_alternate.toml and run/study_mistuning_random.toml (stability) and of
run/study_mistuning_forced.toml (Monte Carlo forced response, `study --forced`).

    .venv/bin/python run/mistuning_results.py out/alternate.h5 out/random.h5 out/forced.h5 \
        --outdir out/figures

Prints the tables (Markdown) and writes mistuning_flutter.png and mistuning_amplification.png.
Every number is read from the files: nothing here computes physics.
"""

from __future__ import annotations

import argparse
import os

import h5py
import numpy as np


def _parameters(f) -> dict[str, np.ndarray]:
    """Per-case values of every study parameter: name -> (cases,)."""
    names = [n.decode() for n in f["/cases/parameters/names"][()]]
    values = f["/cases/parameters/values"][()]
    return {name: values[:, i] for i, name in enumerate(names)}


def flutter(alternate: str, random: str, plt, outdir: str) -> None:
    with h5py.File(alternate, "r") as f:
        p = _parameters(f)
        growth = f["/stability/max_growth_rate"][()]
        amp, angle = p["mistuning.alternate"], p["contacts.shroud.angle_deg"]
    angles = np.unique(angle)
    print("| alternate `a` | " + " | ".join(f"{a:g} deg" for a in angles) + " |")
    print("|---" * (len(angles) + 1) + "|")
    for a in np.unique(amp):
        row = [growth[(amp == a) & (angle == x)][0] for x in angles]
        print(f"| {a:g} | " + " | ".join(f"{g:+.3f}" for g in row) + " |")
    with h5py.File(random, "r") as f:
        p = _parameters(f)
        rgrowth = f["/stability/max_growth_rate"][()]
        std, rangle = p["mistuning.std"], p["contacts.shroud.angle_deg"]
    rangles = np.unique(rangle)
    print()
    print("| random `std` | " + " | ".join(f"{a:g} deg: mean [min, max], stable" for a in rangles)
          + " |")
    print("|---" * (len(rangles) + 1) + "|")
    for s in np.unique(std):
        cells = []
        for x in rangles:
            g = rgrowth[(std == s) & (rangle == x)]
            cells.append(f"{g.mean():+.3f} [{g.min():+.3f}, {g.max():+.3f}], "
                         f"{np.sum(g < 0)}/{g.size}")
        print(f"| {s:g} | " + " | ".join(cells) + " |")
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, x in enumerate(rangles):
        tuned = growth[(amp == 0) & (angle == x)]
        for s in np.unique(std):
            g = rgrowth[(std == s) & (rangle == x)]
            ax.plot(np.full(g.size, 100 * s), g, "o", ms=4, color=colours[i], alpha=0.6)
        alt = [growth[(amp == a) & (angle == x)][0] for a in np.unique(amp)]
        ax.plot(100 * np.unique(amp), alt, "--", color=colours[i],
                label=f"shroud {x:g} deg: alternate (line), random (dots)")
        if tuned.size:
            ax.axhline(tuned[0], color=colours[i], lw=0.5)
    ax.axhline(0.0, color="k", lw=1)
    ax.set_xticks([0, 0.5, 1, 2, 5])
    _finish(fig, ax, plt, "mistuning strength: alternate amplitude a / random std [%]",
            "largest growth rate [1/s]",
            "Flutter of the mistuned wheel (tie-boss 45 deg, mu = 100 N s/m)",
            os.path.join(outdir, "mistuning_flutter.png"))


def _finish(fig, ax, plt, xlabel: str, ylabel: str, title: str, path: str) -> None:
    """Labels, legend, and the figure written to ``path``."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def amplification(path: str, plt, outdir: str) -> None:
    """Amplification factor against the mistuning strength, with and without contacts."""
    with h5py.File(path, "r") as f:
        p = _parameters(f)
        factor = f["/forced/amplification"][()]
        growth = f["/stability/max_growth_rate"][()]
        bound = float(f["/forced"].attrs["whitehead_bound"])
        frequency = f["/forced/peak_frequency_hz"][()]
    std, contacts = p["mistuning.std"], p["forced.contacts"]
    print()
    print("| `std` | contacts linearised: mean, max, peak [Hz] | contacts off: mean, max, "
          "peak [Hz] | largest growth rate [1/s] |")
    print("|---|---|---|---|")
    for s in np.unique(std):
        cells = []
        for c in (1.0, 0.0):
            pick = (std == s) & (contacts == c)
            a = factor[pick]
            cells.append(f"{a.mean():.2f}, {a.max():.2f}, {frequency[pick].min():.1f}-"
                         f"{frequency[pick].max():.1f}")
        g = growth[(std == s) & (contacts == 1.0)]
        print(f"| {100 * s:g} % | " + " | ".join(cells) + f" | {g.min():+.3f}..{g.max():+.3f} |")
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    for c, colour, label in ((1.0, "C0", "contacts linearised"), (0.0, "C1", "contacts off")):
        levels = np.unique(std)
        for s in levels:
            a = factor[(std == s) & (contacts == c)]
            ax.plot(np.full(a.size, 100 * s), a, "o", ms=3, color=colour, alpha=0.5)
        means = [factor[(std == s) & (contacts == c)].mean() for s in levels]
        highs = [factor[(std == s) & (contacts == c)].max() for s in levels]
        ax.plot(100 * levels, means, "-", color=colour, label=f"{label}: mean")
        ax.plot(100 * levels, highs, ":", color=colour, label=f"{label}: largest")
    ax.axhline(bound, color="k", ls="--", lw=1, label=f"Whitehead's bound {bound:.2f}")
    ax.axhline(1.0, color="k", lw=0.5)
    ax.set_xscale("log")
    _finish(fig, ax, plt, "random mistuning std [%]", "amplification factor (peak / tuned peak)",
            "Forced response to the nozzle (ND 2), 66 blades x 22 vectors",
            os.path.join(outdir, "mistuning_amplification.png"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("alternate")
    ap.add_argument("random")
    ap.add_argument("forced", nargs="?", default=None)
    ap.add_argument("--outdir", default="out/figures")
    args = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(args.outdir, exist_ok=True)
    flutter(args.alternate, args.random, plt, args.outdir)
    if args.forced:
        amplification(args.forced, plt, args.outdir)


if __name__ == "__main__":
    main()
