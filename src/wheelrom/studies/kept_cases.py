"""Finished cases kept on disk beside an output while a long command runs (``settle``'s and
the design study's): per case ``case_<i>.npz`` (plain arrays) and ``case_<i>.json`` (its
scalars and the digest of its configuration), each built in memory and renamed into place
once written whole, the JSON last (it marks the case complete). No pickles: a kept case is
data, read back only when its configuration's digest matches.
"""

from __future__ import annotations

import contextlib
import io
import json
import os

import numpy as np

from wheelrom.runtime.outputs import replacing, write_image


def kept_dir(out: str, command: str) -> str:
    """The folder of the finished cases of ``command`` writing ``out``: ``.NAME.command``
    beside it."""
    directory, name = os.path.split(os.path.abspath(out))
    return os.path.join(directory, f".{os.path.splitext(name)[0]}.{command}")


class DamagedCase(Exception):
    """A kept case that cannot be read: ``name`` the file, ``cause`` what its reading
    raised (the message says both, as a warning line starts)."""

    def __init__(self, name: str, cause: BaseException):
        super().__init__(f"{name}: damaged ({type(cause).__name__}: {cause})")
        self.name, self.cause = name, cause


def write_case(directory: str, index: int, scalars: dict, arrays: dict) -> None:
    """Case ``index``'s ``arrays`` and ``scalars`` (JSON; numbers as floats) into
    ``directory`` (made if missing); raises ``OSError`` (a full disk included) and then
    leaves no arrays without their JSON."""
    os.makedirs(directory, exist_ok=True)
    base = os.path.join(directory, f"case_{index}")
    npz = io.BytesIO()
    np.savez(npz, **arrays)
    try:
        for path, data in ((base + ".npz", npz.getvalue()),
                           (base + ".json", json.dumps(scalars, default=float).encode())):
            with replacing(path) as partial:
                write_image(partial, data)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(base + ".npz")  # no arrays without their JSON
        raise


def read_case(directory: str, index: int, digest: str) -> tuple[dict, dict] | None:
    """``(scalars, arrays)`` of case ``index`` kept with configuration ``digest``; None when
    none is kept or another configuration's; :class:`DamagedCase` when it cannot be read."""
    base = os.path.join(directory, f"case_{index}")
    name = base + ".json"
    if not os.path.exists(name):
        return None
    try:
        with open(name, encoding="utf-8") as f:
            scalars = json.load(f)
        if not isinstance(scalars, dict):
            raise ValueError("not a JSON object")
        if scalars.get("digest") != digest:
            return None
        name = base + ".npz"
        # opened here: np.load leaves a file it cannot read as a zip open
        with open(name, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except Exception as exc:  # whatever a damaged file raises (BadZipFile, EOFError, ...)
        raise DamagedCase(name, exc) from None
    return scalars, arrays
