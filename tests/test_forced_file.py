"""The file of ``wheelrom forced-response --out`` (format ``wheelrom-forced-1``): what it
records of the run (configuration, version, the KSP settings the solves used) and what
``wheelrom info`` reads from it, checked against the file's own datasets and the run."""

import json
import os

import h5py
import numpy as np
import pytest

from conftest import SMALL
from wheelrom import __version__, config
from wheelrom.analysis import forced
from wheelrom.cli import main as cli
from wheelrom.rom.model import blade_mistuning
from wheelrom.runtime.environment import petsc

MISTUNED = ["--set", "mistuning.std=0.02", "--set", "mistuning.seed=7"]


@pytest.fixture
def petsc_options():
    """Options put into the PETSc database by a test, taken out again afterwards (the
    database lives as long as the test process)."""
    given = []
    yield given
    db = petsc().Options()
    for name in given:
        if db.hasName(name):
            db.delValue(name)


def _run(capsys, path, *extra) -> dict:
    argv = ["forced-response", SMALL, "--frequencies", "380:395:4", "--json", "--out",
            str(path), *extra]
    assert cli.main(argv) == 0
    return json.loads(capsys.readouterr().out)


@pytest.fixture(scope="module")
def forced_file(tmp_path_factory):
    """A mistuned small wheel, contacts linearised (shroud 50 deg), 4 frequencies."""
    path = tmp_path_factory.mktemp("forced") / "forced.h5"
    argv = ["forced-response", SMALL, "--frequencies", "380:395:4", "--angle", "shroud", "50",
            "--out", str(path), *MISTUNED]
    assert cli.main(argv) == 0
    return path


def _info(path) -> dict:
    from wheelrom.results.info import file_info

    return file_info(str(path))


def test_the_file_records_the_run(forced_file):
    """Configuration text and source, wheelrom version, model size, contact angles and the
    KSP settings of the default solver (preonly + LU, MUMPS when PETSc has it)."""
    cfg = config.load(SMALL, [a for a in MISTUNED if a != "--set"])
    with h5py.File(forced_file, "r") as f:
        attrs = dict(f.attrs)
        delta = f["mistuning"][()]
    assert attrs["config"] == config.to_toml(cfg)
    assert attrs["config_source"] == cfg.source and attrs["wheelrom_version"] == __version__
    assert (attrs["blades"], attrs["modes"]) == (12, 6) and attrs["mistuned"]
    np.testing.assert_array_equal(delta, blade_mistuning(cfg))
    assert json.loads(attrs["contact_angles_deg"]) == {
        "tieboss": cfg.contacts.tieboss.angle_deg, "shroud": 50.0}
    factor = "mumps" if petsc().Sys.hasExternalPackage("mumps") else "petsc"
    assert json.loads(attrs["solver"]) == {"prefix": "forced_", "ksp_type": "preonly",
                                           "pc_type": "lu", "pc_factor_mat_solver_type": factor,
                                           "options": {}}


def test_the_file_records_the_options_given(tmp_path, capsys, petsc_options):
    """Options after ``--`` change the solver and the file says so: PETSc's own LU instead
    of the default factorisation, and the options as given."""
    petsc_options.append("forced_pc_factor_mat_solver_type")
    path = tmp_path / "petsc_lu.h5"
    out = _run(capsys, path, "--no-contacts", "--", "-forced_pc_factor_mat_solver_type", "petsc")
    with h5py.File(path, "r") as f:
        solver = json.loads(f.attrs["solver"])
        amplitude = f["blade_amplitude"][()]
    assert solver["pc_factor_mat_solver_type"] == "petsc"
    assert solver["options"] == {"forced_pc_factor_mat_solver_type": "petsc"}
    assert np.allclose(amplitude.max(axis=1), out["max_amplitude_m"], rtol=1e-12, atol=0)


def test_recorded_settings_are_those_the_solve_used(small_model, small_cfg, petsc_options):
    """:func:`forced.ksp_settings` read before the first solve (what the file records)
    equals what the KSP reports after it has factorised; an iterative KSP records its
    tolerances."""
    K, C = forced.operators(small_model, small_cfg, contacts=False)
    F = forced.nozzle_amplitude(small_model, small_cfg.wheel.stator_vanes, 1.0)
    solver = forced.HarmonicSolver(K, C)
    solver.solve(F, 2 * np.pi * 380.0)
    after = forced.ksp_settings(solver.ksp)
    assert solver.settings == after and after["pc_type"] == "lu"
    solver.destroy()
    db = petsc().Options()
    for name, value in (("forced_ksp_type", "gmres"), ("forced_pc_type", "jacobi"),
                        ("forced_ksp_rtol", "1e-9")):
        petsc_options.append(name)
        db.setValue(name, value)
    iterative = forced.HarmonicSolver(K, C)
    settings = iterative.settings
    iterative.destroy()
    chosen = (settings["ksp_type"], settings["pc_type"], settings["rtol"])
    assert chosen == ("gmres", "jacobi", 1e-9)
    assert "pc_factor_mat_solver_type" not in settings
    assert settings["options"] == {"forced_ksp_rtol": "1e-9", "forced_ksp_type": "gmres",
                                   "forced_pc_type": "jacobi"}


def test_info_json_of_a_forced_file(forced_file, capsys):
    """Every number against the file's datasets: the peaks are the refined ones (at least
    the largest entries of the amplitude tables; the blade where the stored peak amplitudes
    are largest), the amplification factor their ratio, the mistuning range that of the
    configured pattern."""
    assert cli.main(["info", str(forced_file), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    with h5py.File(forced_file, "r") as f:
        delta = f["mistuning"][()]
        amplitude, tuned = f["blade_amplitude"][()], f["tuned_blade_amplitude"][()]
        at_peak = {"peak": f["peak_blade_amplitude"][()],
                   "tuned_peak": f["tuned_peak_blade_amplitude"][()]}
        peak_hz = {"peak": f.attrs["peak_frequency_hz"],
                   "tuned_peak": f.attrs["tuned_peak_frequency_hz"]}
    assert info["kind"] == "forced" and info["format"] == "wheelrom-forced-1"
    assert info["frequency_hz"] == {"from": 380.0, "to": 395.0, "count": 4}
    assert (info["stator_vanes"], info["nodal_diameter"]) == (10, 2)
    assert info["contacts"] and info["contact_angles_deg"]["shroud"] == 50.0
    assert info["mistuned"] and info["mistuning"]["min"] == delta.min() < 0 < delta.max()
    assert info["mistuning"]["max"] == delta.max()
    for key, table in (("peak", amplitude), ("tuned_peak", tuned)):
        assert info[key] == {"amplitude_m": at_peak[key].max(), "frequency_hz": peak_hz[key],
                             "blade": int(np.argmax(at_peak[key]))}
        assert info[key]["amplitude_m"] >= table.max() and 380 <= peak_hz[key] <= 395
    assert info["amplification_factor"] == pytest.approx(
        info["peak"]["amplitude_m"] / info["tuned_peak"]["amplitude_m"], rel=1e-12)
    assert info["amplification_factor"] > 1.05  # the mistuned peak is really another one
    assert (info["blades"], info["modes"], info["frequencies"]) == (12, 6, 4)
    assert info["file_bytes"] == os.path.getsize(forced_file)
    assert info["solver"]["ksp_type"] == "preonly" and info["wheelrom_version"] == __version__


def test_info_text_of_a_forced_file(forced_file, capsys):
    assert cli.main(["info", str(forced_file)]) == 0
    text = capsys.readouterr().out
    info = _info(forced_file)
    peak = info["peak"]
    for line in ("forced response, engine order 10 (ND 2), mistuned wheel",
                 "12 blades x 6 modes, 4 frequencies", "380 .. 395 Hz (4)",
                 "contacts:      linearised (tieboss 45 deg, shroud 50 deg)",
                 f"peak:          {peak['amplitude_m']:.4e} m at {peak['frequency_hz']:g} Hz",
                 f"amplification: {info['amplification_factor']:.4f}",
                 "KSP forced_: preonly/lu/"):
        assert line in text, line


def test_info_of_a_tuned_forced_file_without_contacts(tmp_path, capsys):
    """No mistuning: the configured wheel is the tuned one (factor 1, the same peak), no
    contact angles, a zero pattern."""
    path = tmp_path / "tuned.h5"
    _run(capsys, path, "--no-contacts")
    info = _info(path)
    assert not info["mistuned"] and not info["contacts"] and info["contact_angles_deg"] == {}
    assert info["mistuning"] == {"min": 0.0, "max": 0.0, "std": 0.0}
    assert info["amplification_factor"] == 1.0 and info["peak"] == info["tuned_peak"]
    assert cli.main(["info", str(path)]) == 0
    text = capsys.readouterr().out
    assert "tuned wheel" in text and "contacts:      off\n" in text


def test_info_of_a_file_written_before_the_records(forced_file, tmp_path, capsys):
    """A forced file of the first version (no source, version, size, angles, KSP
    attributes): the same summary, the modes from the stored configuration, None for what
    it does not say."""
    import shutil

    path = tmp_path / "old.h5"
    shutil.copy(forced_file, path)
    with h5py.File(path, "a") as f:
        for name in ("config_source", "wheelrom_version", "mistuned", "solve_s_per_frequency",
                     "blades", "modes", "contact_angles_deg", "solver"):
            del f.attrs[name]
    old, new = _info(path), _info(forced_file)
    for key in ("frequency_hz", "peak", "tuned_peak", "amplification_factor", "mistuning",
                "modes", "blades", "contacts", "nodal_diameter"):
        assert old[key] == new[key], key
    assert old["solver"] is None and old["wheelrom_version"] is None
    assert old["contact_angles_deg"] is None
    assert cli.main(["info", str(path)]) == 0
    assert "wheelrom ?" in capsys.readouterr().out


def test_a_bad_forced_solver_option_is_one_named_line(capsys, petsc_options):
    """``-forced_ksp_type bogus`` is refused up front by the KSP it addresses, in one line
    (and taken out of the options database again: later tests of this process solve)."""
    from wheelrom.cli import main as cli

    petsc_options.append("forced_ksp_type")
    argv = ["forced-response", SMALL, "--frequencies", "100:110:3", "--", "-forced_ksp_type",
            "bogus"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "-forced_ksp_type bogus" in err and "KSP 'forced_'" in err and "Traceback" not in err


def test_figures_of_a_forced_file(forced_file, tmp_path, capsys):
    """`plot` of a forced-response file draws its response curves and the blade amplitudes
    at the peaks (issue #40: it exited 0 with an empty folder)."""
    outdir = tmp_path / "fig"
    assert cli.main(["plot", str(forced_file), "--outdir", str(outdir)]) == 0
    names = sorted(p.name for p in outdir.iterdir())
    assert names == ["forced_localisation.png", "forced_response.png"], names
    for name in names:
        assert (outdir / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_replaces_figures_only_with_force(forced_file, tmp_path, capsys):
    """A second `plot` into the same folder is refused and changes nothing; --force replaces
    the figures; a link in a figure's place is refused even with --force (issue #40)."""
    outdir = tmp_path / "fig"
    argv = ["plot", str(forced_file), "--outdir", str(outdir)]
    assert cli.main(argv) == 0
    mine = outdir / "forced_response.png"
    mine.write_bytes(b"my own figure")
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "forced_response.png" in err and "--force" in err, err
    assert mine.read_bytes() == b"my own figure"
    assert sorted(p.name for p in outdir.iterdir()) == ["forced_localisation.png",
                                                         "forced_response.png"]
    assert cli.main([*argv, "--force"]) == 0
    assert mine.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    mine.unlink()
    mine.symlink_to(victim)
    assert cli.main([*argv, "--force"]) == 2
    assert "not a regular file" in capsys.readouterr().err
    assert victim.read_text() == "keep" and mine.is_symlink()
