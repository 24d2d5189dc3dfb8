"""Small helpers every figure module shares: read a dataset or say it is missing, save PNG
(and PDF), cell edges for maps."""

from __future__ import annotations

import os

import numpy as np

from wheelrom.runtime.errors import InputError


def need(f, name: str, path: str):
    if name not in f:
        raise InputError(f"{path}: dataset '{name}' is missing; cannot draw this figure")
    return f[name][()]


def save(fig, outdir: str, name: str, pdf: bool, written: list[str]) -> None:
    png = os.path.join(outdir, f"{name}.png")
    fig.savefig(png, bbox_inches="tight")
    written.append(png)
    if pdf:
        fig.savefig(os.path.join(outdir, f"{name}.pdf"), bbox_inches="tight")
        written.append(os.path.join(outdir, f"{name}.pdf"))


def cell_edges(centres: np.ndarray, half: float) -> np.ndarray:
    """Cell edges ``(n + 1,)`` around sorted ``centres`` ``(n,)``: midpoints between
    neighbours and mirrored outer edges (matplotlib's ``shading="nearest"``); a single centre
    gets a cell ``half`` either side, so one case or one window still draws a visible cell."""
    c = np.asarray(centres, dtype=float)
    if c.size == 1:
        return np.array([c[0] - half, c[0] + half])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])
