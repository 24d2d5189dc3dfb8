"""The one guarded folder of finished cases kept beside an output (issue #72):
``study --forced-nonlinear``'s ``.NAME.design/`` refuses what ``settle``'s ``.NAME.settle/``
refuses (tests/test_settle_safety.py), up front, and nothing is ever written through a link
or outside the folder, even one planted while the job runs.

Small and fast: the small wheel's design study of two preloads, three frequencies at H = 1
(a few seconds), or no computation at all (a refusal comes before any model is built)."""

import os

import pytest

from conftest import SMALL, one_error
from wheelrom import config
from wheelrom.cli import main as cli
from wheelrom.studies.kept_cases import KeptCases

DESIGN = """
[flutter]
model = "off"
[forced]
points = 3
harmonics = 1
[excitation]
force = 10.0
[study.grid]
"contacts.shroud.normal_preload" = [100.0, 3000.0]
"""


@pytest.fixture
def design_toml(tmp_path):
    """The small wheel with a design study of two preloads (its [sweep] dropped)."""
    text = open(SMALL).read().split("[sweep]")[0] + DESIGN
    path = tmp_path / "design.toml"
    path.write_text(text)
    return path


def _design(toml, out, *extra) -> list[str]:
    return ["study", str(toml), "--stability-only", "--forced-nonlinear", "--out", str(out),
            *extra]


# --- the design study's folder: item 2 ------------------------------------------------------


@pytest.mark.parametrize("resume", [False, True])
def test_a_link_planted_as_the_design_folder_is_refused_never_followed(
        resume, design_toml, tmp_path, capsys, nothing_computed):
    """Issue #72, 2: ``.s.design`` planted as a link to another folder was followed: the
    study's case files were written into the target (the user's ``case_1.json`` there
    overwritten) and left behind. ``settle`` refused the same plant; now the study does, in
    the same words, before any model is built."""
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "case_1.json").write_text('{"mine": 1}')
    side, out = tmp_path / ".s.design", tmp_path / "s.h5"
    side.symlink_to(victim)
    assert cli.main(_design(design_toml, out, *(["--resume"] if resume else []))) == 2
    assert one_error(capsys) == (
        f"wheelrom: --out {out}: {side}, where its finished cases are kept, is a symbolic link "
        "to a directory: a link there is never followed (nor what it points to deleted); "
        "remove the link or choose another name")
    assert os.readlink(side) == str(victim)
    assert os.listdir(victim) == ["case_1.json"]
    assert (victim / "case_1.json").read_text() == '{"mine": 1}'
    assert not out.exists()


def test_a_file_named_as_the_design_folder_is_refused(design_toml, tmp_path, capsys,
                                                      nothing_computed):
    side, out = tmp_path / ".s.design", tmp_path / "s.h5"
    side.write_text("mine")
    assert cli.main(_design(design_toml, out)) == 2
    assert one_error(capsys).endswith(f"{side}, where its finished cases are kept, is a "
                                       "regular file, not a folder: it is never replaced; move "
                                       "it away or choose another name")
    assert side.read_text() == "mine" and not out.exists()


def test_the_design_study_keeps_its_cases_in_its_folder_and_removes_only_them(
        design_toml, tmp_path, capsys):
    """Without a plant the study runs, its folder made and removed (nothing left beside)."""
    out = tmp_path / "s.h5"
    assert cli.main(_design(design_toml, out)) == 0
    assert out.exists() and not (tmp_path / ".s.design").exists()


def test_design_cases_of_another_configuration_are_refused_on_resume(
        design_toml, tmp_path, capsys, nothing_computed):
    """As settle's: --resume refuses the curves kept for another configuration (naming what
    differs) rather than discarding them at the end, and without --resume kept curves are
    discarded only with --force."""
    from wheelrom.config.study import expand

    out, side = tmp_path / "s.h5", tmp_path / ".s.design"
    other = expand(config.load(str(design_toml), ["excitation.force=20.0"])).configs[0]
    KeptCases(str(out), "design").save(0, other, {"status": "done"}, {"x": [1.0]})
    kept = sorted(os.listdir(side))
    assert cli.main(_design(design_toml, out, "--resume")) == 2
    assert one_error(capsys) == (
        f"wheelrom: --out {out}: {side}, where its finished cases are kept, holds case 0, "
        "written for a different configuration (excitation.force: 20.0 -> 10.0): --resume "
        "reuses only this configuration's; --force discards it")
    assert cli.main(_design(design_toml, out)) == 2
    assert one_error(capsys).endswith("holds case 0 kept by an interrupted run: --resume "
                                       "reuses them, --force discards them")
    assert sorted(os.listdir(side)) == kept and not out.exists()


def test_a_folder_replaced_by_a_link_while_the_job_runs_is_never_written_through(tmp_path):
    """Checked up front, the folder can still be swapped for a link before a case is saved:
    the write goes through the folder opened without following a link, so it fails naming
    the folder, and nothing lands in the link's target."""
    cfg = config.load(SMALL)
    folder = KeptCases(str(tmp_path / "s.h5"), "design")
    assert folder.problem([cfg], resume=False, force=False) is None
    victim = tmp_path / "victim"
    victim.mkdir()
    os.symlink(victim, folder.path)
    with pytest.raises(OSError, match=f"{folder.path} is now a symbolic link to a directory"):
        folder.save(0, cfg, {"status": "done"}, {"x": [1.0]})
    assert os.listdir(victim) == []
    folder.clear()  # a link: not ours to remove, nor what it points to
    assert os.path.islink(folder.path) and victim.is_dir()


# --- a kept case that does not fit its case: item 16 ----------------------------------------


def test_a_kept_curve_of_wrong_shapes_is_computed_again(small_model, small_cfg, tmp_path):
    """A kept design curve whose arrays were replaced by a valid npz of other shapes is named
    (its SHA-256, or without one, as a kept case of an older version has none, the first
    array that does not fit) and computed again, never taken as it is."""
    import json

    import numpy as np

    from wheelrom.studies import design_cases
    from wheelrom.studies.forced_nonlinear import design_point

    cfg = small_cfg.replace(**{"flutter.model": "off", "forced.points": 3,
                               "forced.harmonics": 1, "excitation.force": 10.0})
    folder = design_cases.kept_folder(str(tmp_path / "s.h5"))
    assert design_cases.save_point(folder, 0, cfg, design_point(small_model, cfg))
    npz, record = os.path.join(folder.path, "case_0.npz"), os.path.join(folder.path,
                                                                        "case_0.json")
    arrays = dict(np.load(npz))
    arrays["curve_harmonics"] = arrays["curve_harmonics"][:, :2]  # H = 0, not 1
    np.savez(npz, **arrays)
    said = []
    assert design_cases.load_point(folder, 0, cfg, said.append) is None
    assert said == [f"{npz}: damaged (ValueError: its arrays are not the ones its JSON "
                    "recorded (SHA-256 differs: replaced or changed since written)); case 0's "
                    "curve is computed again"]
    with open(record) as fh:
        scalars = json.load(fh)
    del scalars["npz_sha256"]
    with open(record, "w") as fh:
        json.dump(scalars, fh)
    said.clear()
    assert design_cases.load_point(folder, 0, cfg, said.append) is None
    points, modes = arrays["curve_frequency"].size, small_model.modes
    assert said == [f"{record}: damaged (ValueError: array 'curve_harmonics' has shape "
                    f"({points}, 2, {modes}), this case's is ({points}, 3, {modes})); case 0's "
                    "curve is computed again"]


# --- an entry planted inside the folder: item 20 ------------------------------------------


SETTLE = ["contacts.tieboss.enabled=false", "contacts.shroud.enabled=false",
          "sweep.shroud_angles_deg=[50.0, 60.0]", "settle.max_time=0.02",
          "settle.min_time=0.01", "settle.window_periods=2"]


@pytest.mark.parametrize("resume", [False, True])
def test_a_link_planted_as_a_case_file_is_refused_up_front(resume, tmp_path, capsys,
                                                           nothing_computed):
    """Issue #72, 20: a link to a folder planted at ``.s.settle/case_1.json`` was found only
    after the case was computed, and the message called it ``--out``. Now it is refused
    before any model is built, named as what it is, in the folder."""
    victim = tmp_path / "victim"
    victim.mkdir()
    side, out = tmp_path / ".s.settle", tmp_path / "s.h5"
    side.mkdir()
    (side / "case_1.json").symlink_to(victim)
    argv = ["settle", SMALL, *sum((["--set", k] for k in SETTLE), []), "--out", str(out)]
    assert cli.main([*argv, *(["--resume"] if resume else [])]) == 2
    assert one_error(capsys) == (
        f"wheelrom: --out {out}: {side}, where its finished cases are kept, holds "
        f"{side / 'case_1.json'}, which is a symbolic link to a directory, not a kept case: it "
        "is never followed nor replaced; remove it")
    assert os.readlink(side / "case_1.json") == str(victim) and os.listdir(victim) == []


def test_a_case_file_planted_while_the_job_runs_is_never_replaced(tmp_path):
    """Planted after the check, a case's name holding a link (or a folder) is not replaced:
    the save fails naming that path (the command keeps the case in memory), never
    ``--out``."""
    cfg = config.load(SMALL)
    folder = KeptCases(str(tmp_path / "s.h5"), "settle")
    os.mkdir(folder.path)
    victim = tmp_path / "victim"
    victim.mkdir()
    planted = os.path.join(folder.path, "case_1.json")
    os.symlink(victim, planted)
    with pytest.raises(OSError, match=f"{planted} is a symbolic link to a directory, not a "
                                      "kept case: it is never replaced"):
        folder.save(1, cfg, {"status": "done"}, {"x": [1.0]})
    assert os.listdir(folder.path) == ["case_1.json"] and os.path.islink(planted)
    assert os.listdir(victim) == []


def test_settle_keeps_a_case_it_cannot_save_in_memory(tmp_path, capsys, monkeypatch):
    """The case whose save fails on a planted path is written to ``--out`` with the others,
    one warning naming the path (not ``--out``), nothing lost."""
    import h5py

    from wheelrom.studies import settle_cases

    real = settle_cases.save_case

    def planted_then_saved(folder, index, cfg, result):
        if index == 1:  # a link appears at the second case's name while it runs
            os.symlink(tmp_path, os.path.join(folder.path, "case_1.json"))
        return real(folder, index, cfg, result)

    monkeypatch.setattr(settle_cases, "save_case", planted_then_saved)
    out = tmp_path / "s.h5"
    argv = ["settle", SMALL, *sum((["--set", k] for k in SETTLE), []), "--out", str(out)]
    assert cli.main([*argv, "--set", "settle.batch=1"]) == 0
    err = capsys.readouterr().err
    side = tmp_path / ".s.settle"
    [warning] = [ln for ln in err.splitlines() if ln.startswith("wheelrom: warning:")]
    assert warning == (f"wheelrom: warning: {side}: case 1 not saved "
                       f"({side / 'case_1.json'} is a symbolic link to a directory, not a kept "
                       "case: it is never replaced); the finished cases are kept in memory and "
                       "written with the others at the end"), warning
    with h5py.File(out, "r") as f:
        assert f["settle/time"].shape == (2,) and (f["settle/time"][()] > 0).all()
    assert os.listdir(side) == ["case_1.json"]  # the link, not ours to remove
