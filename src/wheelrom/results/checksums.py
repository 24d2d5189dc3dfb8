"""A checksum per case of a sweep, run or study file (``/cases/checksum``, docs/output.md):
CRC-32 of every byte of the case's rows, so that ``wheelrom info --verify`` finds a case
whose stored numbers changed after it was written (a flipped bit on a disk or in a copy).

Why not HDF5's Fletcher32 filter: parallel HDF5 (1.10.8, Debian 12) writes a filtered
dataset only collectively, and the ranks of a sweep write their own cases independently
(measured: "Can't perform independent write with filters in pipeline"). A checksum of our own
works the same in a serial and a parallel file. It is computed from the rows read back right
after they are written (the bytes HDF5 stores, fill values included), so it costs a read of
the case's rows: about 1.4 ms per MB (the tip and state histories dominate; a case of the
paper's sweep, 16 MB, 23 ms against seconds of integration).
"""

from __future__ import annotations

import zlib

import numpy as np

NAME = "checksum"
#: rows that change after the case is written (its status last) or hold the checksum
EXCLUDED = ("status", NAME)


def create_checksums(cases, C: int) -> None:
    """``/cases/checksum`` ``(C,)`` uint32, 0 until a case is written."""
    cases.create_dataset(NAME, (C,), dtype="u4")
    cases[NAME].attrs["meaning"] = ("CRC-32 of the case's row of every other /cases "
                                    "dataset (sorted by path, status excluded); 0: not "
                                    "written")


def _row_datasets(cases) -> list:
    """Every dataset of ``cases`` (recursively, sorted by path) with a row per case."""
    import h5py

    C = cases[NAME].shape[0] if NAME in cases else cases["status"].shape[0]
    found: list = []

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and obj.shape and obj.shape[0] == C and \
                name.rsplit("/", 1)[-1] not in EXCLUDED:
            found.append((name, obj))

    cases.visititems(visit)
    return [obj for _, obj in sorted(found, key=lambda item: item[0])]


def case_checksum(cases, i: int) -> int:
    """CRC-32 of case ``i``'s rows as stored (read back from the file)."""
    crc = 0
    for dataset in _row_datasets(cases):
        crc = zlib.crc32(np.ascontiguousarray(dataset[i]).tobytes(), crc)
    return crc or 1  # 0 means 'not written'


def write_checksum(cases, i: int) -> None:
    """Store case ``i``'s checksum (after its rows, before its status)."""
    if NAME in cases:
        cases[NAME][i] = case_checksum(cases, i)


def verify(cases, written: list[int]) -> dict:
    """Recompute the checksum of the cases ``written`` (done or failed). Returns
    ``{"stored": bool, "checked": n, "mismatched": [case indices]}`` (a file written before
    the checksums: ``stored`` False and nothing checked)."""
    if NAME not in cases:
        return {"stored": False, "checked": 0, "mismatched": []}
    stored = cases[NAME][()]
    mismatched = [i for i in written if stored[i] and case_checksum(cases, i) != stored[i]]
    checked = sum(1 for i in written if stored[i])
    return {"stored": True, "checked": checked, "mismatched": mismatched}
