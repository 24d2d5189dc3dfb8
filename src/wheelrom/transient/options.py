"""The PETSc options a user gives after ``--``, checked before anything is computed.

Each solver of wheelrom reads its own prefix (docs/usage.md): ``wheel_`` (the case TS),
``wheel_K_`` (the ``K_R`` matrix), ``preload_`` (SNES), ``segment_``, ``cyclic_``,
``fullwheel_``, ``stability_`` (SLEPc EPS), ``stability_preload_`` (SNES), ``prestress_``,
``stiffness_`` (KSP), ``limitcycle_`` and ``limitcycle_shooting_`` (SNES),
``limitcycle_floquet_`` (SLEPc EPS). :func:`check` builds a
throw-away object of each prefix the user's options name and lets it read them
(``setFromOptions``, PETSc's own error printing switched off): a value PETSc refuses
(``-wheel_ts_type nosuch``, ``-wheel_ts_dt abc``, ``-segment_eps_type nosuch``), or that its
setter refuses once read (``-limitcycle_snes_max_it -3``: SNES and KSP tolerances are set
again through ``setTolerances``, which checks them), becomes one
:class:`~wheelrom.runtime.errors.InputError` naming that option, found by trying the options of the
failing prefix one at a time. A token after ``--`` that is neither an option nor the value of
the one before it (``-- garbage``), and an option of a wheelrom solver given without the
number it needs (``-wheel_ts_dt`` alone, which PETSc would ignore), are refused too.
:func:`unused` lists, at the end of a command, the options no
solver read (PETSc's ``-options_left``): typically a misspelt name.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools

from wheelrom.runtime.environment import petsc, slepc
from wheelrom.runtime.errors import InputError

# PETSc error codes a bad option value raises (petsc/include/petscerror.h)
_PETSC_ERRORS = {
    56: "not supported",
    60: "nonconforming arguments",
    62: "invalid argument",
    63: "argument out of range",
    73: "object in the wrong state",
    75: "incompatible arguments",
    83: "invalid input",
    86: "unknown type",
}


def _ts(comm):
    from wheelrom.transient import bridge
    from wheelrom.transient.exponential import ExponentialStepper

    PETSc = petsc()
    ts = PETSc.TS().create(comm=comm)
    ts.setType(PETSc.TS.Type.RK)
    ts.setRKType("3bs")
    # a python TS must have its context (PETSc crashes destroying one without): the default's
    if petsc().Options().getString("wheel_ts_type", "") == "python":
        ts.setType(PETSc.TS.Type.PYTHON)
        ts.setPythonContext(ExponentialStepper())
    bridge.set_adapt_type(ts, "none")
    ts.setTimeStep(1e-6)
    return ts


def _matrix(comm):
    PETSc = petsc()
    A = PETSc.Mat().create(comm=comm)
    A.setSizes((1, 1))
    return A


def _ksp(comm):
    ksp = petsc().KSP().create(comm=comm)
    ksp.setType("preonly")
    return ksp


def _eps(comm):
    return slepc().EPS().create(comm=comm)


def _snes(comm):
    return petsc().SNES().create(comm=comm)


# longest prefix first: "wheel_K_" before "wheel_"
SOLVERS = {
    "wheel_K_": ("Mat", _matrix),
    "wheel_": ("TS", _ts),
    "limitcycle_shooting_": ("SNES", _snes),
    "limitcycle_floquet_": ("EPS", _eps),
    "limitcycle_": ("SNES", _snes),
    "stability_preload_": ("SNES", _snes),
    "preload_": ("SNES", _snes),
    "forced_preload_": ("SNES", _snes),
    "forced_": ("KSP", _ksp),
    "stability_": ("EPS", _eps),
    "segment_": ("EPS", _eps),
    "cyclic_": ("EPS", _eps),
    "fullwheel_": ("EPS", _eps),
    "prestress_": ("KSP", _ksp),
    "stiffness_": ("KSP", _ksp),
    "attachment_": ("KSP", _ksp),
}


def option_names(args: list[str]) -> list[str]:
    """The option names (without dash) among command-line tokens: ``-wheel_ts_dt 1e-6`` ->
    ``["wheel_ts_dt"]`` (a negative number is a value, not an option)."""
    names = []
    for token in args:
        if token.startswith("-") and len(token) > 1 and not _is_number(token):
            names.append(token.lstrip("-"))
    return names


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def solver_of(name: str) -> str | None:
    """The prefix of the wheelrom solver that reads option ``name``, if any."""
    return next((prefix for prefix in SOLVERS if name.startswith(prefix)), None)


@contextlib.contextmanager
def _silent():
    """PETSc errors raise ``PETSc.Error`` without PETSc printing its traceback."""
    PETSc = petsc()
    PETSc.Sys.pushErrorHandler("ignore")
    try:
        yield
    finally:
        PETSc.Sys.popErrorHandler()


def _accepts(prefix: str) -> int:
    """0 if a fresh object of ``prefix`` reads the database without error, else the error
    code."""
    PETSc = petsc()
    kind, create = SOLVERS[prefix]
    obj = create(PETSc.COMM_SELF)
    try:
        obj.setOptionsPrefix(prefix)
        with _silent():
            obj.setFromOptions()
            _recheck(kind, obj)
        if kind == "TS" and obj.getTimeStep() <= 0:
            return 63
        return 0
    except PETSc.Error as exc:
        return int(exc.ierr)
    finally:
        obj.destroy()


def _recheck(kind: str, obj) -> None:
    """Set the tolerances ``setFromOptions`` read again through their setters, which refuse
    what the options reader lets through (a negative ``max_it`` or tolerance: PETSc error
    63); for a SNES, those of its KSP too. ``-2`` (PETSc's "default" to a setter) is
    refused as well: read from the options it would stay as the iteration limit."""
    PETSc = petsc()
    if kind == "SNES":
        tolerances = obj.getTolerances()  # rtol, atol, stol, max_it
        obj.setTolerances(*tolerances)
        obj.setMaxFunctionEvaluations(obj.getMaxFunctionEvaluations())
        if min(tolerances) < 0:
            raise PETSc.Error(63)
        obj = obj.getKSP()
        kind = "KSP"
    if kind == "KSP":
        rtol, atol, divtol, max_it = obj.getTolerances()
        obj.setTolerances(rtol, atol, divtol, max_it)
        if min(rtol, atol, max_it) < 0:
            raise PETSc.Error(63)


def _alone(names: list[str], keep: str):
    """Context: every option of ``names`` but ``keep`` taken out of the database."""
    db = petsc().Options()
    saved = {n: db.getString(n) for n in names if n != keep and db.hasName(n)}

    @contextlib.contextmanager
    def scope():
        for n in saved:
            db.delValue(n)
        try:
            yield
        finally:
            for n, value in saved.items():
                db.setValue(n, value)

    return scope()


def forget_reads(names: list[str]) -> None:
    """Re-insert ``names`` so that PETSc forgets they were read (by the probes, or by a TS
    that does not act on them): the unused-option warning must reflect what took effect."""
    db = petsc().Options()
    for name in names:
        if db.hasName(name):
            value = db.getString(name, "")
            db.delValue(name)
            db.setValue(name, value)


def check(args: list[str]) -> None:
    """Raise an :class:`InputError` naming the first option of ``args`` (the tokens after
    ``--``, already in the database) that its solver refuses."""
    _check_tokens(args)
    names = option_names(args)
    try:
        _check(names)
        _check_values(args)
    finally:
        forget_reads(names)


def _check_tokens(args: list[str]) -> None:
    """A token that is neither an option nor the value right after one: a typo PETSc would
    silently skip (``-- garbage``, ``-- -wheel_ts_dt 1e-6 2e-6``)."""
    after_option = False
    for token in args:
        if _is_option(token):
            after_option = True
        elif after_option:
            after_option = False  # the option's value
        else:
            raise InputError(f"PETSc options after --: '{token}' is neither an option "
                             "(-name) nor the value of the option before it")


def _is_option(token: str) -> bool:
    return token.startswith("-") and len(token) > 1 and not _is_number(token)


def _without_value(args: list[str]) -> list[str]:
    """The option names of ``args`` given without a value (the next token is an option,
    or there is none)."""
    return [token.lstrip("-") for token, nxt in zip(args, [*args[1:], None], strict=True)
            if _is_option(token) and (nxt is None or _is_option(nxt))]


def _check_values(args: list[str]) -> None:
    """An option of a wheelrom solver given without a value although its solver reads a
    number there (``-wheel_ts_dt`` alone): PETSc ignores it silently. Found by giving it a
    word for a value: a number option refuses it (error 63), a flag or a viewer does not."""
    db = petsc().Options()
    names = option_names(args)
    for name in _without_value(args):
        prefix = solver_of(name)
        if prefix is None:
            continue
        mine = [n for n in names if solver_of(n) == prefix]
        with _alone(mine, name):
            db.setValue(name, "true")
            try:
                code = _accepts(prefix)
            finally:
                db.delValue(name)
                db.setValue(name, None)
        if code == 63:
            raise InputError(f"PETSc option -{name}: needs a value (-{name} <number>): "
                             f"the {SOLVERS[prefix][0]} '{prefix}' reads a number there")


def _check(names: list[str]) -> None:
    db = petsc().Options()
    for prefix in SOLVERS:
        mine = [n for n in names if solver_of(n) == prefix]
        if not mine or not (code := _accepts(prefix)):
            continue
        kind = SOLVERS[prefix][0]
        for name in mine:  # which one: try each alone
            with _alone(mine, name):
                code_alone = _accepts(prefix)
            if code_alone:
                code = code_alone
                break
        else:
            name = " ".join("-" + n for n in mine)
        value = db.getString(name, "") if db.hasName(name) else ""
        why = _PETSC_ERRORS.get(code, f"PETSc error {code}")
        if code == 63 and value and not _is_number(value):
            why = "expects a number"  # PETSc: "Input string ... has no numeric value"
        elif code == 63 and name == "wheel_ts_dt":
            why = "the time step must be positive"
        shown = f"-{name} {value}".strip() if " " not in name else name
        raise InputError(f"PETSc option {shown}: refused by the {kind} '{prefix}' ({why})")


@functools.cache
def _options_used():
    fn = ctypes.CDLL(petsc().__file__).PetscOptionsUsed
    fn.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.POINTER(ctypes.c_int)]
    fn.restype = ctypes.c_int
    return fn


def was_read(name: str) -> bool:
    """Whether something read option ``name`` (no dash) of the database
    (``PetscOptionsUsed``)."""
    petsc()
    flag = ctypes.c_int()
    return _options_used()(None, name.encode(), ctypes.byref(flag)) == 0 and bool(flag.value)


def unused(args: list[str]) -> list[str]:
    """The options of ``args`` that nothing has read so far (``PetscOptionsUsed``)."""
    if not args:
        return []
    petsc()
    flag = ctypes.c_int()
    left = []
    for name in option_names(args):
        # PETSc keeps the names without the dash
        if _options_used()(None, name.encode(), ctypes.byref(flag)) == 0 and not flag.value:
            left.append(name)
    return left
