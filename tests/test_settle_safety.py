"""`wheelrom settle` never loses a user's file nor computes on a wrong input:
--resume refuses a file of another kind (only --force replaces it); the side folder
``.NAME.settle`` is refused up front when it is a planted link (never followed, its target
untouched) or a file, and a damaged case in it is computed again; a --cycles file of another
kind or of another wheel is refused before any model is built. The files of other kinds are
made here with their format attribute (what the checks read), in milliseconds."""

import os

import h5py
import numpy as np
import pytest

from conftest import SMALL, VDP_WHEEL, one_error
from wheelrom import config
from wheelrom.cli import main as cli

#: the Van der Pol wheel, one case, a few ms of simulated time (no window completes)
SHORT = [*VDP_WHEEL, "sweep.shroud_angles_deg=[50.0]", "settle.max_time=0.02",
         "settle.min_time=0.01", "settle.window_periods=2"]
#: format and top-level group of each kind of file, and what the refusal calls it
KINDS = {
    "run": ("wheelrom-sweep-1", "cases", "a sweep or run results file"),
    "stability": ("wheelrom-stability-1", "stability", "a stability file"),
    "limit-cycle": ("wheelrom-limit-cycle-1", "limit_cycle", "a limit-cycle file"),
    "settle": ("wheelrom-settle-1", "settle", "a settle file"),
}


def _settle(*extra: str) -> list[str]:
    return ["settle", SMALL, *sum((["--set", k] for k in SHORT), []), *extra]


def _wheelrom_file(path, kind: str, overrides=()) -> bytes:
    """A file of ``kind`` (KINDS, or ``text``: not HDF5) written for the small wheel with
    ``overrides``; its bytes."""
    if kind == "text":
        path.write_text("precious, not HDF5\n")
    else:
        fmt, group, _ = KINDS[kind]
        cfg = config.load(SMALL, [*SHORT, *overrides])
        with h5py.File(path, "w") as f:
            f.attrs["format"] = fmt
            f.attrs["config"] = config.to_toml(cfg)
            f.attrs["config_source"] = cfg.source
            f.create_group(group)
    return path.read_bytes()


# --- --resume on a file of another kind ----------------------------------------------------


@pytest.mark.parametrize("kind", ["run", "stability", "limit-cycle", "text"])
def test_resume_refuses_a_file_of_another_kind(kind, tmp_path, capsys, nothing_computed):
    """It was replaced by the settle file without --force."""
    out = tmp_path / "x.h5"
    before = _wheelrom_file(out, kind)
    assert cli.main(_settle("--resume", "--out", str(out))) == 2
    line = one_error(capsys)
    words = KINDS[kind][2] if kind != "text" else "a file that is not HDF5"
    assert line.startswith(f"wheelrom: --out {out}: is {words}"), line
    assert "not a settle file" in line and "--force" in line
    assert out.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["x.h5"]


def test_resume_refuses_every_existing_file_naming_why(tmp_path):
    """What --resume continues is the cases kept beside a settle file not yet written: a
    settle file of another configuration was replaced without --force (and the kept cases
    of its run deleted), one of this configuration was computed again; a bare HDF5 file is
    another kind."""
    from wheelrom.studies.settle import resume_problem

    settle, bare = tmp_path / "s.h5", tmp_path / "bare.h5"
    _wheelrom_file(settle, "settle")
    cfg = config.load(SMALL, SHORT)
    assert resume_problem(str(settle), cfg) == (
        f"--out {settle}: already holds every case of this configuration (a settle file is "
        "written once all are done): nothing to resume; --force computes it again")
    other = config.load(SMALL, [*SHORT, "sweep.shroud_angles_deg=[60.0]"])
    assert resume_problem(str(settle), other) == (
        f"--out {settle}: was written for a different configuration (sweep.shroud_angles_deg: "
        "[50.0] -> [60.0]); choose another --out, or --force to replace it")
    h5py.File(bare, "w").close()
    assert "is an HDF5 file without a wheelrom format" in resume_problem(str(bare), cfg)


def _interrupted_run(tmp_path, monkeypatch, *extra: str) -> None:
    """A settle of ``extra`` into ``tmp_path/s.h5`` stopped once every case is kept beside
    it, before its file is written (Ctrl-C there)."""
    def interrupted(*_):
        raise KeyboardInterrupt

    with monkeypatch.context() as patch:
        patch.setattr("wheelrom.results.settle.write_settle", interrupted)
        assert cli.main(_settle(*extra, "--out", str(tmp_path / "s.h5"))) == 130


def _tree(folder) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_resume_of_another_configuration_keeps_the_file_and_the_kept_cases(
        tmp_path, monkeypatch, capsys):
    """Issue #72, 1: a complete settle file of shroud 50 deg and the kept cases of its run;
    ``--resume`` at 60 deg exited 0, replaced the file without --force and deleted the kept
    cases. Now the file is refused naming the change, and the kept cases of the other
    configuration, the file gone, are refused too (as ``study --resume`` refuses a file
    "written for a different configuration"); nothing is touched, nothing computed."""
    _interrupted_run(tmp_path, monkeypatch)
    folder, out = tmp_path / ".s.settle", tmp_path / "s.h5"
    kept = _tree(folder)
    assert sorted(kept) == ["case_0.json", "case_0.npz"]
    before = _wheelrom_file(out, "settle")
    capsys.readouterr()

    def computed(*_):
        raise AssertionError("a segment was built: the refusal came too late")

    monkeypatch.setattr("wheelrom.segment.load.build_builtin", computed)
    sixty = ("--set", "sweep.shroud_angles_deg=[60.0]")
    assert cli.main(_settle(*sixty, "--resume", "--out", str(out))) == 2
    assert one_error(capsys) == (
        f"wheelrom: --out {out}: was written for a different configuration "
        "(sweep.shroud_angles_deg: [50.0] -> [60.0]); choose another --out, or --force to "
        "replace it")
    assert out.read_bytes() == before and _tree(folder) == kept
    out.unlink()
    assert cli.main(_settle(*sixty, "--resume", "--out", str(out))) == 2
    assert one_error(capsys) == (
        f"wheelrom: --out {out}: {folder}, where its finished cases are kept, holds case 0, "
        "written for a different configuration (contacts.shroud.angle_deg: 50.0 -> 60.0, "
        "sweep.shroud_angles_deg: [50.0] -> [60.0]): --resume reuses only this "
        "configuration's; --force discards it")
    assert _tree(folder) == kept and not out.exists()


def test_kept_cases_are_discarded_only_with_force(tmp_path, monkeypatch, capsys):
    """A run without --resume deleted the cases an interrupted run kept, unasked; now they
    are discarded only with --force (as an existing file is replaced)."""
    _interrupted_run(tmp_path, monkeypatch)
    folder, out = tmp_path / ".s.settle", tmp_path / "s.h5"
    kept = _tree(folder)
    capsys.readouterr()
    assert cli.main(_settle("--out", str(out))) == 2
    assert one_error(capsys) == (
        f"wheelrom: --out {out}: {folder}, where its finished cases are kept, holds case 0 "
        "kept by an interrupted run: --resume reuses them, --force discards them")
    assert _tree(folder) == kept and not out.exists()
    assert cli.main(_settle("--out", str(out), "--force")) == 0
    assert out.exists() and not folder.exists()


def test_resume_with_force_or_without_out_is_refused(tmp_path, capsys, nothing_computed):
    """Issue #72, 22: ``settle --force --resume`` and ``--resume`` without ``--out`` were
    accepted (``sweep`` refuses both): the first as ``sweep`` does, a usage error, the other
    in one line naming the option."""
    with pytest.raises(SystemExit) as stop:
        cli.main(_settle("--out", str(tmp_path / "s.h5"), "--force", "--resume"))
    assert stop.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "wheelrom settle: error: argument --resume: not allowed with argument --force")
    assert cli.main(_settle("--resume")) == 2
    assert one_error(capsys) == ("wheelrom: --resume: continues the cases an interrupted run "
                                  "kept beside its --out; give that --out")
    assert os.listdir(tmp_path) == []


# --- the side folder .NAME.settle -----------------------------------------------------------


@pytest.mark.parametrize("resume", [False, True])
def test_a_link_planted_as_the_side_folder_is_refused_never_followed(resume, tmp_path, capsys,
                                                                    nothing_computed):
    """It was written through (the cases landed in its target), then rmtree raised
    "Cannot call rmtree on a symbolic link" after the computation."""
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "mine").write_text("not yours")
    side = tmp_path / ".s.settle"
    side.symlink_to(victim)
    out = tmp_path / "s.h5"
    assert cli.main(_settle("--out", str(out), *(["--resume"] if resume else []))) == 2
    line = one_error(capsys)
    assert f"--out {out}: {side}, where its finished cases are kept, is a symbolic link to a " \
        "directory: a link there is never followed" in line, line
    assert os.path.islink(side) and os.readlink(side) == str(victim)
    assert os.listdir(victim) == ["mine"] and (victim / "mine").read_text() == "not yours"
    assert not out.exists()


@pytest.mark.parametrize("resume", [False, True])
def test_a_file_named_as_the_side_folder_is_refused_up_front(resume, tmp_path, capsys,
                                                             nothing_computed):
    """It raised FileExistsError when the first case was saved: after computing it."""
    side = tmp_path / ".s.settle"
    side.write_text("mine")
    out = tmp_path / "s.h5"
    assert cli.main(_settle("--out", str(out), *(["--resume"] if resume else []))) == 2
    line = one_error(capsys)
    assert f"{side}, where its finished cases are kept, is a regular file" in line, line
    assert side.read_text() == "mine" and not out.exists()


def test_a_damaged_saved_case_is_computed_again(tmp_path, monkeypatch, capsys):
    """A case_0.npz cut short (a full disk, a kill) raised zipfile.BadZipFile on --resume:
    it is now missing, said in one line, and the case computed again."""
    from wheelrom.studies import settle as study

    out = tmp_path / "s.h5"

    def interrupted(*_):  # the cases are saved beside the output, the file is not written
        raise KeyboardInterrupt

    monkeypatch.setattr("wheelrom.results.settle.write_settle", interrupted)
    assert cli.main(_settle("--out", str(out))) == 130
    monkeypatch.undo()
    saved = tmp_path / ".s.settle" / "case_0.npz"
    saved.write_bytes(saved.read_bytes()[: saved.stat().st_size // 2])
    capsys.readouterr()
    real, calls = study._settle_batch, []
    monkeypatch.setattr(study, "_settle_batch", lambda *a, **k: calls.extend(a[4]) or real(*a, **k))
    assert cli.main(_settle("--out", str(out), "--resume")) == 0
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    [line] = [ln for ln in err.splitlines() if "damaged" in ln]
    assert line.startswith(f"{saved}: damaged (BadZipFile: ") and "computed again" in line
    assert len(calls) == 1
    with h5py.File(out, "r") as f:
        assert f.attrs["format"] == "wheelrom-settle-1" and f["settle/verdict"].shape == (1,)
    assert not (tmp_path / ".s.settle").exists()


def _wrong_shapes(npz) -> None:
    """``npz`` replaced by a valid npz of the same arrays for a wheel of 5 blades."""
    arrays = dict(np.load(npz))
    arrays.update(amplitude=arrays["amplitude"][:5], tip=arrays["tip"][:, :5],
                  window_amplitude=arrays["window_amplitude"][:, :5])
    np.savez(npz, **arrays)


@pytest.mark.parametrize("recorded", [True, False])
def test_a_kept_case_of_wrong_shapes_is_computed_again(recorded, tmp_path, monkeypatch,
                                                       capsys):
    """Issue #72, 16: a kept ``case_0.npz`` replaced by a valid npz with wrong shapes was
    taken as is on --resume (and the file written from it, whose checksums then agreed).
    Its JSON records the npz's SHA-256 (``recorded``), and the arrays must fit the case (a
    kept case of an older version, without the SHA-256): either way it is named and the
    case computed again."""
    import json

    _interrupted_run(tmp_path, monkeypatch)
    folder, out = tmp_path / ".s.settle", tmp_path / "s.h5"
    npz, record = folder / "case_0.npz", folder / "case_0.json"
    _wrong_shapes(npz)
    if not recorded:
        scalars = json.loads(record.read_text())
        del scalars["npz_sha256"]
        record.write_text(json.dumps(scalars))
    capsys.readouterr()
    assert cli.main(_settle("--out", str(out), "--resume")) == 0
    err = capsys.readouterr().err
    [line] = [ln for ln in err.splitlines() if "damaged" in ln]
    why = ("its arrays are not the ones its JSON recorded (SHA-256 differs: replaced or "
           "changed since written)") if recorded else \
        "array 'window_amplitude' has shape (1, 5), this case's is (1, 12)"  # its one window
    where = npz if recorded else record
    assert line == f"{where}: damaged (ValueError: {why}); case 0 is computed again", line
    with h5py.File(out, "r") as f:
        assert f["settle/case_0/amplitude"].shape == (12,)
        assert f["settle/case_0/tip"].shape[1:] == (12, 3)


def test_info_verify_names_a_case_that_does_not_fit_its_wheel(tmp_path, capsys):
    """Issue #72, 16: a settle file written whole from a case of the wrong shapes had
    checksums that agree: ``info --verify`` said "all intact". It now names the case and
    the array, exit 1."""
    from wheelrom.results.file_checksums import GROUP, write_file_checksums

    out = tmp_path / "s.h5"
    assert cli.main(_settle("--out", str(out))) == 0
    with h5py.File(out, "a") as f:  # as if written from a 5-blade case: checksums agree
        case = f["settle/case_0"]
        amplitude = case["amplitude"][:5]
        del case["amplitude"], f[GROUP]
        case["amplitude"] = amplitude
        write_file_checksums(f, {"settle": 1})
    capsys.readouterr()
    assert cli.main(["info", str(out), "--verify"]) == 1
    captured = capsys.readouterr()
    [checks] = [ln for ln in captured.out.splitlines() if "checksums:" in ln]
    assert checks.endswith(" checked: INCONSISTENT with the wheel: case 0 "
                           "(settle/case_0/amplitude: shape (5,), the wheel's 12 blades want "
                           "(12,))"), checks
    assert captured.err.startswith(f"wheelrom: {out}: case 0 (settle/case_0/amplitude: shape "
                                   "(5,)"), captured.err


def test_interrupt_and_resume_number_the_cases_from_0(tmp_path):
    """Issue #72, 17: the interrupt and resume messages counted cases from 1 ("case 2 of 3"),
    while the kept files (``case_1.json``), ``info`` and ``--confirm`` count from 0. The
    second of three cases kept is now case 1 everywhere."""
    import argparse

    from wheelrom.cli.settle import _interrupted
    from wheelrom.config.study import expand
    from wheelrom.studies.settle_cases import kept_folder

    cfg = config.load(SMALL, [*SHORT, "sweep.shroud_angles_deg=[50.0, 60.0, 70.0]"])
    out = tmp_path / "s.h5"
    folder = kept_folder(str(out))
    folder.save(1, expand(cfg).configs[1], {"status": "done"}, {"x": np.zeros(1)})
    args = argparse.Namespace(out=str(out), cycles=None)
    assert str(_interrupted(args, cfg)).startswith(
        f"interrupted: case 1 of 0..2 finished and kept in {folder.path}; to compute only the "
        "other 2, rerun the settle with --resume")


def test_resume_runs_a_batch_kept_in_part_again_whole(tmp_path, monkeypatch, capsys):
    """A batch's windows depend on its members (``settle.batch``): ``--resume`` reuses a
    batch only when every case of it was kept, runs one kept in part again whole (its cases
    alone would take other windows than the uninterrupted run's), and leaves one kept whole."""
    from wheelrom.studies import settle as study

    out = tmp_path / "s.h5"
    three = ["--set", "sweep.shroud_angles_deg=[50.0, 60.0, 70.0]", "--set", "settle.batch=2"]

    def interrupted(*_):  # the cases are saved beside the output, the file is not written
        raise KeyboardInterrupt

    monkeypatch.setattr("wheelrom.results.settle.write_settle", interrupted)
    assert cli.main(_settle(*three, "--out", str(out))) == 130
    monkeypatch.undo()
    folder = tmp_path / ".s.settle"
    kept = {i: np.load(folder / f"case_{i}.npz")["amplitude"] for i in range(3)}
    for name in ("case_1.npz", "case_1.json"):  # the second of the first batch (0, 1) lost
        (folder / name).unlink()
    real, calls = study._settle_batch, []
    monkeypatch.setattr(study, "_settle_batch", lambda *a, **k: calls.append(a[4]) or real(*a, **k))
    assert cli.main(_settle(*three, "--out", str(out), "--resume")) == 0
    assert len(calls) == 1 and [label[:10] for label in calls[0]] == ["[case 0/2]", "[case 1/2]"]
    assert "[case 2/2] tieboss.angle_deg 45, shroud.angle_deg 70: kept" in capsys.readouterr().err
    with h5py.File(out, "r") as f:
        for i in range(3):
            np.testing.assert_array_equal(f[f"settle/case_{i}/amplitude"][()], kept[i])


# --- --cycles -----------------------------------------------------------------------------


@pytest.mark.parametrize("override, changed", [("wheel.blades=10", "wheel.blades: 10 -> 12"),
                                               ("wheel.modes_per_segment=4",
                                                "wheel.modes_per_segment: 4 -> 6")])
def test_cycles_of_another_wheel_are_refused_naming_the_key(override, changed, tmp_path, capsys,
                                                            nothing_computed):
    """Another blade count was wrapped onto this wheel; another mode count was a numpy
    broadcast error."""
    cycles = tmp_path / "lc.h5"
    _wheelrom_file(cycles, "limit-cycle", [override])
    assert cli.main(_settle("--cycles", str(cycles))) == 2
    line = one_error(capsys)
    assert line.startswith(f"wheelrom: --cycles {cycles}: written for another wheel "
                           f"({changed})"), line


@pytest.mark.parametrize("kind", ["stability", "run", "settle", "text"])
def test_cycles_of_another_kind_are_refused_naming_it(kind, tmp_path, capsys, nothing_computed):
    """They failed every case after the model build with a raw KeyError or OSError."""
    cycles = tmp_path / "other.h5"
    _wheelrom_file(cycles, kind)
    assert cli.main(_settle("--cycles", str(cycles))) == 2
    words = KINDS[kind][2] if kind != "text" else "a file that is not HDF5"
    assert one_error(capsys) == (f"wheelrom: --cycles {cycles}: is {words}"
                                  + (f" (format {KINDS[kind][0]!r})" if kind != "text" else "")
                                  + ", not a limit-cycle file (wheelrom limit-cycle --out)")


def _with_orbit(path, angles=(np.nan, np.nan)) -> None:
    """One exact orbit (every blade 1 um in its first mode, ND 6 at 116.5 Hz) at the contact
    ``angles`` (tieboss, shroud; NaN: that contact not enabled) added to the limit-cycle file
    ``path``."""
    state = np.zeros((1, 2, 12, 6))
    state[0, 0, :, 0] = 1e-6
    with h5py.File(path, "a") as f:
        g = f["limit_cycle"]
        g["angles_deg"] = np.array([angles], dtype=float)
        c = g.create_group("case_0/wave_6/cycles")
        c["orbit_state"], c["orbit_period"] = state, np.array([1 / 116.5])
        c["tip_amplitude"] = np.array([1e-5])


@pytest.mark.parametrize("held", [True, False])
def test_cycles_of_other_angles_are_refused_naming_them(held, tmp_path, capsys,
                                                        nothing_computed):
    """Issue #72, 9: a --cycles file without the case's angles was silently ignored (the
    cycle computed again, and when none was found the run fell back to the preload while
    ``info`` said "start cycle"). Now it is refused before any model is built, naming the
    cases and the angles the file holds."""
    contacts = ["contacts.tieboss.enabled=true", "contacts.shroud.enabled=true"]
    cycles = tmp_path / "lc.h5"
    _wheelrom_file(cycles, "limit-cycle", contacts)
    if held:
        _with_orbit(cycles, (45.0, 50.0))
    argv = _settle("--cycles", str(cycles), *sum((["--set", k] for k in contacts), []),
                   "--set", "sweep.shroud_angles_deg=[60.0, 70.0]")
    assert cli.main(argv) == 2
    holds = "it holds tieboss 45 deg, shroud 50 deg" if held else "it holds no case"
    assert one_error(capsys) == (
        f"wheelrom: --cycles {cycles}: holds no limit cycle for cases 0..1 (tieboss 45 deg, "
        f"shroud 60 deg, ...): {holds}; give the limit-cycle file of these angles, or no "
        "--cycles (their cycles are then computed here)")


def test_a_case_the_cycles_file_holds_without_a_cycle_starts_from_the_preload(
        tmp_path, capsys, monkeypatch):
    """Issue #72, 9: a case the file holds but whose continuation found no cycle (an
    elastic-law file of the small wheel) had its cycle computed again, then fell back to the
    preload unsaid. The file's word is taken: no cycle is computed, and the start says
    why."""
    import json

    def computed(*_, **__):
        raise AssertionError("the cycle was computed again")

    monkeypatch.setattr("wheelrom.analysis.periodic.limit_cycle.case_limit_cycles", computed)
    cycles = tmp_path / "lc.h5"
    _wheelrom_file(cycles, "limit-cycle")
    _with_orbit(cycles)
    with h5py.File(cycles, "a") as f:  # the wave's continuation found no bounded cycle
        c = f["limit_cycle/case_0/wave_6/cycles"]
        for name in list(c):
            del c[name]
        c["tip_amplitude"] = np.zeros(0)
    out = tmp_path / "s.h5"
    assert cli.main(_settle("--cycles", str(cycles), "--json", "--out", str(out))) == 0
    row = json.loads(capsys.readouterr().out)["cases"][0]
    assert row["start"].startswith("the preloaded equilibrium (lc.h5 holds no cycle at these "
                                   "angles), the growing modes of waves "), row["start"]
    assert cli.main(["info", str(out)]) == 0  # it said "start cycle" and nothing else
    shown = capsys.readouterr().out.splitlines()
    assert "(start cycle, 1 of 1 case(s) from the preloaded equilibrium (no cycle found), " \
        "windows of 2 periods" in shown[0], shown[0]
    assert shown[-1].endswith(" in the last window (started from the preloaded equilibrium)")


def test_info_says_how_max_time_ends_the_run(tmp_path, capsys):
    """Issue #72, 26: an elastic-law settle ran past ``settle.max_time`` by up to half a
    window while ``info`` said "at most". The run is whole windows, the last the one ending
    nearest ``max_time`` (so that ``min_time = max_time`` is reached); ``info`` now says so,
    and the run's end is that window's: within half a window of it."""
    out = tmp_path / "s.h5"
    keys = ['contacts.law="elastic"', 'settle.start="preload"', "settle.window_periods=2",
            "settle.min_time=0.04", "settle.max_time=0.04",
            "sweep.shroud_angles_deg=[50.0]"]
    assert cli.main(["settle", SMALL, *sum((["--set", k] for k in keys), []), "--out",
                     str(out)]) == 0
    with h5py.File(out, "r") as f:
        ends = f["settle/case_0/window_end"][()]
    window = ends[0]
    assert ends[-1] > 0.04 and abs(ends[-1] - 0.04) <= 0.5 * window  # past it, the nearest
    capsys.readouterr()
    assert cli.main(["info", str(out)]) == 0
    title = capsys.readouterr().out.splitlines()[0]
    assert title.endswith("until the window ending nearest 0.04 s)") and "at most" not in title


def test_info_of_a_preload_start_says_so(tmp_path, capsys):
    """Issue #72, 10: ``info`` of a settle started from the preload said "(started at 0
    um)", the stored value being NaN (no cycle)."""
    out = tmp_path / "s.h5"
    assert cli.main(_settle("--set", 'settle.start="preload"', "--out", str(out))) == 0
    with h5py.File(out, "r") as f:
        assert np.isnan(f["settle/start_amplitude"][0])
    capsys.readouterr()
    assert cli.main(["info", str(out)]) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert last.endswith(" um in the last window (started from the preloaded equilibrium)"), last


def test_cycles_with_a_preload_start_are_refused(tmp_path, capsys, nothing_computed):
    """``settle.start = "preload"`` reads no cycle: a --cycles beside it was ignored."""
    cycles = tmp_path / "lc.h5"
    _wheelrom_file(cycles, "limit-cycle")
    _with_orbit(cycles)
    assert cli.main(_settle("--cycles", str(cycles), "--set", 'settle.start="preload"')) == 2
    assert one_error(capsys) == (
        f"wheelrom: --cycles {cycles}: settle.start = 'preload' starts from the preloaded "
        "equilibrium and reads no cycle; drop --cycles, or set settle.start = 'cycle'")


@pytest.mark.parametrize("where, what", [("folder", "a directory"),
                                         ("/dev/null", "a character device"),
                                         ("missing", None)])
def test_cycles_that_is_no_file_is_named_as_what_it_is(where, what, tmp_path, capsys,
                                                       nothing_computed):
    """Issue #72, 18: ``--cycles <folder>`` and ``--cycles /dev/null`` said "no such file"."""
    path = {"folder": str(tmp_path), "missing": str(tmp_path / "lc.h5")}.get(where, where)
    assert cli.main(_settle("--cycles", path)) == 2
    assert one_error(capsys) == (
        f"wheelrom: --cycles {path}: is {what}, not a limit-cycle file (wheelrom limit-cycle "
        "--out)" if what else f"wheelrom: --cycles {path}: no such file")


def test_cycles_of_the_same_wheel_at_another_intensity_are_accepted(tmp_path):
    """Only the wheel must agree: the orbit of another flutter intensity, time step or
    harmonic count is still a start in this model's coordinates."""
    from wheelrom.runtime.errors import InputError
    from wheelrom.studies.settle import check_cycles

    cycles = tmp_path / "lc.h5"
    _wheelrom_file(cycles, "limit-cycle", ["flutter.mu=5.0", "time.step=5e-6",
                                           "limit_cycle.harmonics=3",
                                           "contacts.shroud.angle_deg=60.0"])
    _with_orbit(cycles)
    cfg = config.load(SMALL, SHORT)
    check_cycles(str(cycles), cfg)
    with pytest.raises(InputError, match="contacts.tieboss.height: 1.6 -> 1.7"):
        check_cycles(str(cycles), config.load(SMALL, [*SHORT, "contacts.tieboss.height=1.7"]))


def test_the_orbit_of_a_wheel_without_contacts_is_read_from_the_file(tmp_path, capsys):
    """A limit-cycle file records the angles of the enabled contacts only (NaN for the
    others); settle looked its case up by both angles, never found it on a wheel with a
    contact disabled and computed the orbit again. A file with one orbit (every blade 1 um
    in its first mode) is now the start."""
    import json


    cycles = tmp_path / "lc.h5"
    _wheelrom_file(cycles, "limit-cycle")
    _with_orbit(cycles)
    assert cli.main(_settle("--cycles", str(cycles), "--json")) == 0
    row = json.loads(capsys.readouterr().out)["cases"][0]
    assert row["start"].startswith("the exact orbit in lc.h5"), row["start"]
