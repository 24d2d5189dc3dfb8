"""Small helpers every figure module shares: read a dataset or say it is missing, save PNG
(and PDF) into a staging folder moved into place only when nothing is clobbered, cell edges
for maps, the blade-amplitude (localisation) bars."""

from __future__ import annotations

import contextlib
import os
import shutil
import stat
import tempfile

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


@contextlib.contextmanager
def staged(outdir: str, force: bool):
    """``(staging folder, written list)`` to draw into; on a clean exit the figures move into
    ``outdir`` under their names, and ``written`` then holds the final paths. An existing
    figure of the same name is replaced only with ``force``, and never something that is not
    a regular file: otherwise :class:`InputError` names them and nothing is moved. The staging
    folder goes in every case, and ``outdir`` too when this call created it and it stays
    empty (an error leaves no empty folder behind)."""
    created = not os.path.isdir(outdir)
    os.makedirs(outdir, exist_ok=True)
    staging = tempfile.mkdtemp(prefix=".figures-", dir=outdir)
    written: list[str] = []
    try:
        yield staging, written
        written[:] = _move_into_place(written, outdir, force)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        if created and not os.listdir(outdir):
            os.rmdir(outdir)


def _move_into_place(drawn: list[str], outdir: str, force: bool) -> list[str]:
    targets = [os.path.join(outdir, os.path.basename(p)) for p in drawn]
    present = [t for t in targets if os.path.lexists(t)]
    odd = [t for t in present if not stat.S_ISREG(os.lstat(t).st_mode)]
    if odd:
        raise InputError(f"{odd[0]}: exists and is not a regular file (a link, a folder or a "
                         "device); figures replace only regular files")
    if present and not force:
        names = ", ".join(os.path.basename(t) for t in present[:3])
        more = f" and {len(present) - 3} more" if len(present) > 3 else ""
        raise InputError(f"{outdir}: {names}{more} exist; --force replaces them (or choose "
                         "another --outdir)")
    for source, target in zip(drawn, targets, strict=True):
        os.replace(source, target)
    return targets


def localisation_bars(ax, blades: np.ndarray, tuned: np.ndarray, label: str,
                      tuned_label: str) -> None:
    """Blade tip amplitudes ``(N,)`` [m] as bars, the tuned wheel's ``(N,)`` as a step line."""
    s = np.arange(blades.size)
    ax.bar(s, blades, color="tab:blue", label=label)
    ax.step(np.r_[s - 0.5, s[-1] + 0.5], np.r_[tuned, tuned[-1]], where="post", color="k",
            label=tuned_label)
    ax.set_xlabel("blade")
    ax.set_ylabel("tip amplitude at the peak [m]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")


def cell_edges(centres: np.ndarray, half: float) -> np.ndarray:
    """Cell edges ``(n + 1,)`` around sorted ``centres`` ``(n,)``: midpoints between
    neighbours and mirrored outer edges (matplotlib's ``shading="nearest"``); a single centre
    gets a cell ``half`` either side, so one case or one window still draws a visible cell."""
    c = np.asarray(centres, dtype=float)
    if c.size == 1:
        return np.array([c[0] - half, c[0] + half])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])
