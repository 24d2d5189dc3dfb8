"""Finished cases kept on disk beside an output while a long command runs: ``settle``'s
``.NAME.settle/`` and the design study's ``.NAME.design/`` (and any later command's), all
through one guarded folder, :class:`KeptCases`.

Per case ``case_<i>.npz`` (plain arrays) and ``case_<i>.json`` (its scalars, the
configuration it was computed with, that configuration's digest and the SHA-256 of the
npz), each built in memory and renamed into place once written whole, the JSON last (it
marks the case complete). No pickles: a kept case is data, read back only when its
configuration's digest matches and its arrays are the ones its JSON recorded.

The folder is checked before anything is computed (:meth:`KeptCases.problem`): a link there
is never followed, a file of that name or a folder holding anything but kept cases is never
emptied, a case file that is not a regular file is refused, cases kept for another
configuration are refused on ``--resume`` (as a results file of another configuration is),
and cases kept by an interrupted run are discarded only with ``--force``. Every write and
removal then goes through a descriptor of the folder opened without following a link, so
nothing is ever written or removed outside it, even if it is replaced while the job runs.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import io
import json
import os
import re
import secrets
import stat

import numpy as np

from wheelrom.config import Config, to_toml
from wheelrom.runtime.errors import InputError
from wheelrom.runtime.outputs import not_a_regular_file

#: a kept case's files, and the temporaries they are written under (a killed write's leftovers)
_CASE = re.compile(r"case_(\d+)\.(json|npz)\Z")
_PARTIAL = re.compile(r"\.case_\d+\.[A-Za-z0-9_]{8}\.partial\.(json|npz)\Z")
#: the longest list of names a refusal quotes
_NAMES_SHOWN = 3


def kept_dir(out: str, command: str) -> str:
    """The folder of the finished cases of ``command`` writing ``out``: ``.NAME.command``
    beside it."""
    directory, name = os.path.split(os.path.abspath(out))
    return os.path.join(directory, f".{os.path.splitext(name)[0]}.{command}")


def config_digest(cfg: Config) -> str:
    """The digest a kept case records of its configuration (its TOML without comments)."""
    return hashlib.sha256(to_toml(cfg, comments=False).encode()).hexdigest()[:16]


class DamagedCase(Exception):
    """A kept case that cannot be read: ``name`` the file, ``cause`` what its reading
    raised (the message says both, as a warning line starts)."""

    def __init__(self, name: str, cause: BaseException):
        super().__init__(f"{name}: damaged ({type(cause).__name__}: {cause})")
        self.name, self.cause = name, cause


def _listed(names: list[str]) -> str:
    shown = ", ".join(names[:_NAMES_SHOWN])
    return shown + (f" and {len(names) - _NAMES_SHOWN} more" if len(names) > _NAMES_SHOWN
                    else "")


def case_numbers(indices) -> str:
    """``"case 2"``, ``"cases 0..3, 5"``: case indices counted from 0, as the files, ``info``
    and ``--confirm`` count them."""
    values = sorted(set(indices))
    runs, start = [], None
    for k, v in enumerate(values):
        start = v if start is None else start
        if k + 1 == len(values) or values[k + 1] != v + 1:
            runs.append(f"{start}" if start == v else f"{start}..{v}")
            start = None
    return f"case{'s' if len(values) > 1 else ''} {', '.join(runs)}"


class KeptCases:
    """The folder ``.NAME.command`` beside the output ``out`` where ``command`` keeps its
    finished cases until its file is written (module docstring); ``flag`` names the output's
    option in refusals."""

    def __init__(self, out: str, command: str, flag: str = "--out"):
        self.out, self.flag = out, flag
        self.path = kept_dir(out, command)

    # ------------------------------------------------------------ before anything is computed
    def problem(self, configs: list[Config], resume: bool, force: bool) -> InputError | None:
        """Why the folder cannot serve a run of the cases ``configs`` (None: it can): one line
        naming it (module docstring). ``resume``: its cases are to be reused, so each must
        be of its case's configuration; else they are discarded, which only ``force`` may."""
        where = f"{self.flag} {self.out}: {self.path}, where its finished cases are kept,"
        try:
            mode = os.lstat(self.path).st_mode
        except FileNotFoundError:
            return None
        if stat.S_ISLNK(mode):
            what = not_a_regular_file(self.path) or "a symbolic link to a regular file"
            return InputError(f"{where} is {what}: a link there is never followed (nor what "
                              "it points to deleted); remove the link or choose another name")
        if not stat.S_ISDIR(mode):
            what = "a regular file" if stat.S_ISREG(mode) else not_a_regular_file(self.path)
            return InputError(f"{where} is {what}, not a folder: it is never replaced; move it "
                              "away or choose another name")
        if not os.access(self.path, os.W_OK | os.X_OK):
            return InputError(f"{where} is not writable")
        names = sorted(os.listdir(self.path))
        foreign = [n for n in names if not (_CASE.match(n) or _PARTIAL.match(n))]
        if foreign:
            return InputError(f"{where} holds {_listed(foreign)}, which wheelrom did not write: "
                              "it is never emptied; move it away or choose another name")
        for name in names:
            path = os.path.join(self.path, name)
            what = _not_a_plain_file(path)
            if what:
                return InputError(f"{where} holds {path}, which is {what}, not a kept case: "
                                  "it is never followed nor replaced; remove it")
        cases = sorted({int(m.group(1)) for n in names if (m := _CASE.match(n))})
        if not cases:
            return None  # empty, or a killed write's temporaries: nothing computed is there
        if not resume:
            if force:
                return None
            return InputError(f"{where} holds {case_numbers(cases)} kept by an interrupted run: "
                              "--resume reuses them, --force discards them")
        return self._configuration_problem(where, cases, configs)

    def _configuration_problem(self, where: str, cases: list[int],
                               configs: list[Config]) -> InputError | None:
        """Why a kept case is not of its case's configuration (None: every readable one is;
        an unreadable JSON is damaged, computed again with a warning)."""
        from wheelrom.results.layout import config_changes

        for i in cases:
            scalars = self._scalars(i)
            if scalars is None:
                continue
            if i >= len(configs):
                return InputError(f"{where} holds case {i}, written for a different "
                                  f"configuration (this one has cases 0..{len(configs) - 1}): "
                                  "--resume reuses only this configuration's; --force "
                                  "discards it")
            if scalars.get("digest") == config_digest(configs[i]):
                continue
            changed = config_changes(scalars.get("config"), configs[i]) \
                if "config" in scalars else None
            return InputError(f"{where} holds case {i}, written for a different configuration"
                              f"{f' ({changed})' if changed else ''}: --resume reuses only "
                              "this configuration's; --force discards it")
        return None

    def _scalars(self, index: int) -> dict | None:
        """Case ``index``'s JSON as a dict; None: none, or not readable."""
        try:
            with self._open_file(f"case_{index}.json") as fh:
                scalars = json.load(fh)
        except (OSError, ValueError):
            return None
        return scalars if isinstance(scalars, dict) else None

    # ------------------------------------------------------------ the folder, never a link
    def _folder(self, create: bool = False) -> int | None:
        """A descriptor of the folder opened without following a link (None: missing and not
        ``create``); raises ``OSError`` when a link or anything but a folder is there."""
        if create:
            with contextlib.suppress(FileExistsError):
                os.mkdir(self.path)
        try:
            return os.open(self.path, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
        except FileNotFoundError:
            if create:
                raise
            return None
        except OSError as exc:
            if exc.errno in (errno.ELOOP, errno.ENOTDIR):
                what = not_a_regular_file(self.path) or "a regular file"
                raise OSError(exc.errno, f"{self.path} is now {what}, not the folder of the "
                              "kept cases: nothing is written there") from None
            raise

    @contextlib.contextmanager
    def _open_file(self, name: str):
        """The kept file ``name`` opened for reading (binary), never through a link."""
        fd = self._folder()
        if fd is None:
            raise FileNotFoundError(errno.ENOENT, "no folder of kept cases", self.path)
        try:
            handle = os.open(name, os.O_RDONLY | os.O_NOFOLLOW, dir_fd=fd)
        finally:
            os.close(fd)
        with os.fdopen(handle, "rb") as fh:
            yield fh

    def kept(self, configs: list[Config]) -> dict[int, str]:
        """``{index: status}`` of the cases kept with their case's configuration (what
        ``--resume`` reuses)."""
        out = {}
        for i, cfg in enumerate(configs):
            scalars = self._scalars(i)
            if scalars is not None and scalars.get("digest") == config_digest(cfg):
                out[i] = str(scalars.get("status"))
        return out

    def clear(self) -> None:
        """Remove the kept cases and the folder: its own files only (a name it did not write,
        or a link or folder planted at a case's name since it was checked, stays, and so
        does the folder then)."""
        try:
            fd = self._folder()
        except OSError:
            return  # a link or a file now: not ours to remove
        if fd is None:
            return
        try:
            for name in os.listdir(fd):
                if (_CASE.match(name) or _PARTIAL.match(name)) and _regular(fd, name):
                    with contextlib.suppress(FileNotFoundError):
                        os.unlink(name, dir_fd=fd)
        finally:
            os.close(fd)
        with contextlib.suppress(OSError):  # not empty, or no longer a folder: left alone
            os.rmdir(self.path)

    # ------------------------------------------------------------ one case
    def save(self, index: int, cfg: Config, scalars: dict, arrays: dict) -> None:
        """Case ``index``'s ``arrays`` and ``scalars`` (JSON; numbers as floats) of the
        configuration ``cfg`` into the folder (made if missing); raises ``OSError`` (a full
        disk included; a path planted meanwhile named) and then leaves no arrays without
        their JSON."""
        npz = io.BytesIO()
        np.savez(npz, **arrays)
        data = npz.getvalue()
        record = {**scalars, "digest": config_digest(cfg),
                  "config": to_toml(cfg, comments=False),
                  "npz_sha256": hashlib.sha256(data).hexdigest()}
        fd = self._folder(create=True)
        base = f"case_{index}"
        try:
            for name, content in ((base + ".npz", data),
                                  (base + ".json", json.dumps(record, default=float).encode())):
                self._write(fd, name, content)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(base + ".npz", dir_fd=fd)  # no arrays without their JSON
            raise
        finally:
            os.close(fd)

    def _write(self, fd: int, name: str, content: bytes) -> None:
        """``content`` as ``name`` in the folder ``fd``: into a new temporary there (created
        exclusively, never through a link), flushed, then renamed onto ``name`` unless
        something other than a regular file is there."""
        stem, ext = os.path.splitext(name)
        partial = f".{stem}.{secrets.token_hex(4)}.partial{ext}"
        handle = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o666,
                         dir_fd=fd)
        try:
            with os.fdopen(handle, "wb") as fh:
                fh.write(content)
                fh.flush()
                os.fsync(fh.fileno())
            with contextlib.suppress(FileNotFoundError):
                mode = os.stat(name, dir_fd=fd, follow_symlinks=False).st_mode
                if not stat.S_ISREG(mode):
                    path = os.path.join(self.path, name)
                    raise OSError(errno.EEXIST, f"{path} is {not_a_regular_file(path)}, not a "
                                  "kept case: it is never replaced")
            os.replace(partial, name, src_dir_fd=fd, dst_dir_fd=fd)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(partial, dir_fd=fd)
            raise

    def read(self, index: int, cfg: Config) -> tuple[dict, dict] | None:
        """``(scalars, arrays)`` of case ``index`` kept with the configuration ``cfg``; None
        when none is kept or another configuration's; :class:`DamagedCase` when it cannot be
        read or its arrays are not the ones its JSON recorded."""
        base = os.path.join(self.path, f"case_{index}")
        name = base + ".json"
        try:
            with self._open_file(f"case_{index}.json") as fh:
                scalars = json.load(fh)
        except FileNotFoundError:
            return None
        except Exception as exc:  # whatever a damaged file raises
            raise DamagedCase(name, exc) from None
        try:
            if not isinstance(scalars, dict):
                raise ValueError("not a JSON object")
            if scalars.get("digest") != config_digest(cfg):
                return None
            name = base + ".npz"
            with self._open_file(f"case_{index}.npz") as fh:
                data = fh.read()
            with np.load(io.BytesIO(data), allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
            recorded = scalars.get("npz_sha256")  # (kept cases of older versions: none)
            if recorded is not None and hashlib.sha256(data).hexdigest() != recorded:
                raise ValueError("its arrays are not the ones its JSON recorded (SHA-256 "
                                 "differs: replaced or changed since written)")
        except Exception as exc:  # BadZipFile, EOFError, a link (ELOOP), ...
            raise DamagedCase(name, exc) from None
        return scalars, arrays


def _regular(fd: int, name: str) -> bool:
    """Whether ``name`` in the folder ``fd`` is a regular file itself (not a link)."""
    try:
        return stat.S_ISREG(os.stat(name, dir_fd=fd, follow_symlinks=False).st_mode)
    except FileNotFoundError:
        return False


def _not_a_plain_file(path: str) -> str | None:
    """What ``path`` is when not a regular file itself (a link, even to a regular file, is
    named); None: a regular file."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:  # gone meanwhile (a write of this job's finishing)
        return None
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISLNK(mode):
        return not_a_regular_file(path) or "a symbolic link to a regular file"
    return not_a_regular_file(path)


def expect_shapes(arrays: dict, shapes: dict[str, tuple]) -> None:
    """Raise ``ValueError`` naming the first array of ``shapes`` (name -> shape, ``None`` for
    an axis of any length) missing from ``arrays`` or of another shape: a kept case is read
    back only when it fits the case it is taken for."""
    for name, shape in shapes.items():
        if name not in arrays:
            raise ValueError(f"no array {name!r}")
        got = np.shape(arrays[name])
        if len(got) != len(shape) or any(w is not None and g != w
                                          for g, w in zip(got, shape, strict=True)):
            want = "(" + ", ".join("n" if w is None else str(w) for w in shape) + \
                ("," if len(shape) == 1 else "") + ")"
            raise ValueError(f"array {name!r} has shape {got}, this case's is {want}")
