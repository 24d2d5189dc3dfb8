"""Checksums of the files written in one piece (stability, limit-cycle, settle,
forced-response, ``modes --out`` and ``study --stability-only`` files; docs/output.md
"Checksums"): a CRC-32 of every dataset's values and of every attribute as stored, kept in
``/checksums``, so that ``wheelrom info --verify`` names the dataset or attribute whose
stored value changed after it was written (a flipped bit on a disk or in a copy) and the
case it belongs to. A dataset with a row per case (``rows``) has a checksum per row: a
change is named by its case.

A sweep, ``run --out`` or study file with transients has a checksum per case instead
(:mod:`.checksums`): its cases are written one at a time, by the rank that ran them.
Computed from the values read back once the file is complete, the bytes HDF5 stores.
"""

from __future__ import annotations

import re
import zlib

import numpy as np

GROUP = "checksums"
_CASE = re.compile(r"(?:^|/)case_(\d+)(?:[/@]|$)")


def _bytes(value) -> bytes:
    """The bytes of a value as h5py reads it back: strings as UTF-8, variable-length items
    one by one (an object array's own bytes are addresses), arrays with dtype and shape."""
    import h5py

    if isinstance(value, str):
        return value.encode("utf-8", "surrogateescape")
    if isinstance(value, bytes):
        return value
    if isinstance(value, h5py.Empty):
        return b"<empty>"
    a = np.asarray(value)
    head = f"{a.dtype.str}{a.shape}".encode()
    if a.dtype == object:
        return head + b"\0".join(_bytes(x) for x in a.ravel())
    return head + np.ascontiguousarray(a).tobytes()


def _crc(value) -> int:
    return zlib.crc32(_bytes(value))


def _entries(f, rows: dict[str, int]) -> list[tuple[str, int, int]]:
    """``(path, row, crc)`` of every attribute (``object@name``; the file's own ``@name``)
    and every dataset (row -1: all of it; a dataset of a group in ``rows`` whose first axis
    has that many entries: one per row), sorted by path; ``/checksums`` left out."""
    import h5py

    objects = [("", f)]
    f.visititems(lambda name, obj: objects.append((name, obj)) if name != GROUP and
                 not name.startswith(GROUP + "/") else None)
    out = []
    for path, obj in sorted(objects, key=lambda item: item[0]):
        out += [(f"{path}@{name}", -1, _crc(obj.attrs[name])) for name in sorted(obj.attrs)]
        if not isinstance(obj, h5py.Dataset):
            continue
        data = obj[()]
        count = rows.get(path.rpartition("/")[0])
        if count is not None and obj.ndim and obj.shape[0] == count:
            out += [(path, i, _crc(data[i])) for i in range(count)]
        else:
            out.append((path, -1, _crc(data)))
    return out


def write_file_checksums(f, rows: dict[str, int] | None = None) -> None:
    """``/checksums`` of the complete file ``f``: ``path`` (the dataset, or ``object@name``
    of an attribute), ``row`` (the case of a per-case dataset's row; -1: all of it) and
    ``crc32``. ``rows``: group path -> number of cases, for the groups whose datasets hold a
    row per case. The last thing written."""
    entries = _entries(f, rows or {})
    g = f.create_group(GROUP)
    g.attrs["meaning"] = ("CRC-32 of every dataset (of each row of a per-case dataset) and of "
                          "every attribute, as stored: wheelrom info --verify recomputes them")
    paths = [p.encode() for p, _, _ in entries]
    g["path"] = np.array(paths, dtype=f"S{max(map(len, paths), default=1)}")
    g["row"] = np.array([r for _, r, _ in entries], dtype=np.int64)
    g["crc32"] = np.array([c for _, _, c in entries], dtype=np.uint32)


def _now(f, path: str, row: int, cache: dict) -> int | None:
    """The CRC-32 of ``path`` (row ``row``) as the file holds it now; None: it is gone."""
    name, at, attribute = path.partition("@")
    obj = f[name] if name else f
    if at:
        return _crc(obj.attrs[attribute]) if attribute in obj.attrs else None
    if name not in cache:
        cache[name] = obj[()]
    data = cache[name]
    if row < 0:
        return _crc(data)
    return _crc(data[row]) if row < len(data) else None


def verify_file(f) -> dict:
    """Recompute every checksum of ``/checksums``. Returns ``{"stored": bool, "checked": n,
    "mismatched": [{"path", "case"}]}``: each dataset, row or attribute whose value changed
    (or is gone) since it was written, with its case when it belongs to one (None: the
    model, the configuration, ...). A file without them: ``stored`` False, nothing checked."""
    if GROUP not in f:
        return {"stored": False, "checked": 0, "mismatched": []}
    g = f[GROUP]
    paths = [p.decode() for p in g["path"][()]]
    cache: dict = {}
    mismatched = []
    for path, row, crc in zip(paths, g["row"][()], g["crc32"][()], strict=True):
        try:
            now = _now(f, path, int(row), cache)
        except (KeyError, OSError, ValueError):  # gone, or no longer readable (a compressed
            now = None  # chunk whose bytes changed may not inflate)
        if now != int(crc):
            case = int(row) if row >= 0 else (int(m.group(1)) if (m := _CASE.search(path))
                                              else None)
            mismatched.append({"path": path, "case": case})
    return {"stored": True, "checked": len(paths), "mismatched": mismatched}
