"""``wheelrom study`` end to end (subprocesses, as users run it): a mixed-model study is
bitwise the same on 1 and 2 ranks, builds each model once, agrees with ``wheelrom
stability`` case by case; the screen runs exactly the boundary cases; resume, refusals,
info and figures; format-1 files still read."""

import json
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest

from conftest import HANG_S, SMALL

WHEELROM = [sys.executable, "-m", "wheelrom.cli.main"]
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1", MPLBACKEND="Agg")
BASE = """[wheel]
blades = 12
stator_vanes = 10
modes_per_segment = 6
basis = "free"
[segment]
preset = "coarse"
[time]
step = 5e-6
end = 0.002
window = 0.0005
"""  # tests/data/small.toml without its [sweep]
MIXED = BASE + """[study.grid]
wheel.modes_per_segment = [4, 6]
contacts.shroud.angle_deg = [20.0, 80.0]
friction.static = [0.6, 0.8]
"""
# tie-boss x shroud with one stable corner (0 deg shroud at 30 deg tie-boss)
ANGLES = BASE + """[study.grid]
contacts.tieboss.angle_deg = [30.0, 60.0]
contacts.shroud.angle_deg = "0:90:30"
"""
# timing and the rank count, not the physics
# the checksum covers the wall times too
NOT_PHYSICS = ("cases/wall_s", "cases/compile_s", "cases/batch", "stability/wall_s",
               "cases/checksum")
# differ in the last bits from run to run even serially (so does `wheelrom stability`):
# the gap amplitudes of transient.stability's mode description; every other number is bitwise
LAST_BIT = ("stability/contact_normal", "stability/contact_tangential")


def wheelrom(*args, ranks=1, check=True):
    cmd = WHEELROM + [str(a) for a in args]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), *cmd]
    res = subprocess.run(cmd, env=ENV, capture_output=True, text=True, timeout=HANG_S)
    if check and res.returncode:
        raise AssertionError(f"{cmd} exited {res.returncode}:\n{res.stderr[-3000:]}")
    return res


def figures(path, outdir) -> set[str]:
    """The file names ``wheelrom plot`` writes."""
    res = wheelrom("plot", path, "--outdir", outdir)
    return {os.path.basename(p) for p in res.stdout.split()}


def toml(tmp_path, text, name="study.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def physics(path):
    out = {}
    with h5py.File(path, "r") as f:

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and name not in NOT_PHYSICS:
                out[name] = obj[()]

        f.visititems(visit)
    return out


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    """The mixed-model study (2 models x 2 angles x 2 frictions), full transients, 1 rank."""
    tmp = tmp_path_factory.mktemp("study")
    cfg = toml(tmp, MIXED)
    res = wheelrom("study", cfg, "--out", tmp / "n1.h5")
    return cfg, tmp / "n1.h5", res.stderr


def test_two_ranks_bitwise_equal_one_rank_for_mixed_models(mixed, tmp_path):
    cfg, n1, _ = mixed
    log = wheelrom("study", cfg, "--out", tmp_path / "n2.h5", ranks=2).stderr
    assert "model 2/2 (4 case(s)): 12 blades x 6 modes, built by rank 1" in log
    a, b = physics(n1), physics(tmp_path / "n2.h5")
    assert a.keys() == b.keys()
    assert all(s == b"done" for s in a["cases/status"])
    assert np.isfinite(a["cases/max_tip_amplitude"]).all()
    for key in a:
        if key in LAST_BIT:
            np.testing.assert_allclose(a[key], b[key], rtol=1e-12, atol=1e-14, err_msg=key)
            continue
        assert np.array_equal(a[key], b[key], equal_nan=a[key].dtype.kind == "f"), key


def test_each_model_is_built_once_and_shared(mixed):
    _, n1, log = mixed
    assert "2 model(s)" in log
    assert log.count("model 1/2 (4 case(s)): 12 blades x 4 modes, built by rank 0") == 1
    assert log.count("model 2/2 (4 case(s)): 12 blades x 6 modes, built by rank 0") == 1
    with h5py.File(n1, "r") as f:
        assert f.attrs["format"] == "wheelrom-sweep-2"
        assert f["cases/model"][()].tolist() == [0, 0, 0, 0, 1, 1, 1, 1]
        assert [f[f"models/{g}"].attrs["modes"] for g in (0, 1)] == [4, 6]
        names = [n.decode() for n in f["cases/parameters/names"][()]]
        assert names == ["wheel.modes_per_segment", "contacts.shroud.angle_deg",
                         "friction.static"]
        assert f["cases/parameters/values"][5].tolist() == [6.0, 20.0, 0.8]
        assert f["cases/selected_by"][()].tolist() == [b"all"] * 8
        # a 4-mode case's stability is padded to the 6-mode size
        assert (f["stability/nodal_diameter"][0] == -1).sum() == 2 * (6 - 4) * 7


def test_stability_of_a_case_equals_the_stability_command(mixed, tmp_path):
    _, n1, _ = mixed
    out = tmp_path / "direct.h5"
    wheelrom("stability", SMALL, "--out", out, "--set", "wheel.modes_per_segment=6",
             "--set", "friction.static=0.8", "--set", "sweep.shroud_angles_deg=[20.0]",
             "--set", "sweep.tieboss_angles_deg=[45.0]")
    with h5py.File(n1, "r") as study, h5py.File(out, "r") as direct:
        for name in ("growth_rate", "frequency_hz", "nodal_diameter", "normal_force",
                     "equilibrium", "modal_share"):
            ours, theirs = study[f"stability/{name}"][5], direct[f"stability/{name}"][0]
            assert np.array_equal(ours, theirs), name
        assert study["stability/verdict"][5] == direct["stability/verdict"][0]
        # and the transient's linear columns agree with the stability group
        assert study["cases/linear_growth_rate"][5] == study["stability/max_growth_rate"][5]
        # every case: the transient's classification uses its fastest stored mode
        for name in ("growth_rate", "nodal_diameter", "frequency_hz"):
            np.testing.assert_array_equal(study[f"cases/linear_{name}"][()],
                                          study[f"stability/{name}"][:, 0], err_msg=name)


def _brute_boundary(verdicts, shape):
    grid = np.array(verdicts).reshape(shape)
    out = np.zeros(shape, dtype=bool)
    for i in range(shape[0]):
        for j in range(shape[1]):
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                a, b = i + di, j + dj
                if 0 <= a < shape[0] and 0 <= b < shape[1] and grid[a, b] != grid[i, j]:
                    out[i, j] = True
    return out.reshape(-1)


def test_screen_runs_exactly_the_boundary_cases_and_the_confirmed(tmp_path):
    out = tmp_path / "screen.h5"
    wheelrom("study", toml(tmp_path, ANGLES), "--out", out, "--screen", "--confirm", "7")
    with h5py.File(out, "r") as f:
        verdicts = [v.decode() for v in f["stability/verdict"][()]]
        chosen = [s.decode() for s in f["cases/selected_by"][()]]
        status = [s.decode() for s in f["cases/status"][()]]
        assert np.isfinite(f["stability/max_growth_rate"][()]).all()  # every case's stability
        amplitude = f["cases/max_tip_amplitude"][()]
    edge = _brute_boundary(verdicts, (2, 4))
    assert 0 < edge.sum() < 8  # the map has a boundary and cases away from it
    for i in range(8):
        words = {(True, False): "boundary", (False, True): "user",
                 (True, True): "boundary+user", (False, False): "none"}
        expected = words[(bool(edge[i]), i == 7)]
        assert chosen[i] == expected, i
        assert status[i] == ("skipped" if expected == "none" else "done"), i
        assert np.isfinite(amplitude[i]).all() == (expected != "none"), i


def test_resume_runs_the_pending_cases_to_the_same_numbers(mixed, tmp_path):
    cfg, n1, _ = mixed
    copy = tmp_path / "resume.h5"
    shutil.copy(n1, copy)
    with h5py.File(copy, "r+") as f:
        f["cases/status"][3] = b"pending"
        f["cases/max_tip_amplitude"][3] = np.nan
    assert f"1 case(s) pending: rerun the study with --resume: wheelrom study {cfg} --out {copy}" \
        " --resume" in wheelrom("info", copy).stdout
    res = wheelrom("study", cfg, "--out", copy, "--resume")
    assert "1 transient(s) to run" in res.stderr
    a, b = physics(n1), physics(copy)
    for key in a:
        assert np.array_equal(a[key], b[key], equal_nan=a[key].dtype.kind == "f"), key


def test_existing_file_and_other_mode_are_refused(mixed):
    cfg, n1, _ = mixed
    res = wheelrom("study", cfg, "--out", n1, check=False)
    assert res.returncode == 2 and "exists: pass --resume to complete it or --force" in res.stderr
    res = wheelrom("study", cfg, "--out", n1, "--screen", "--resume", check=False)
    assert res.returncode == 2 and "was written by a 'full' study, this is 'screen'" in res.stderr


@pytest.mark.parametrize("args, message", [
    (["--confirm", "1"], "--confirm names the cases --screen must run; it needs --screen"),
    (["--screen", "--confirm", "99"], "--confirm: case indices are 0..7, got 99"),
    (["--screen", "--confirm", "a"], "--confirm: 'a' is not a case index"),
    (["--set", "study.grid.friction.statik=[1]"],
     "study.grid.friction.statik: unknown key ('statik' is not in friction)"),
])
def test_bad_arguments_are_one_line(tmp_path, args, message):
    res = wheelrom("study", toml(tmp_path, ANGLES), "--out", tmp_path / "x.h5", *args,
                   check=False)
    assert res.returncode == 2
    assert message in res.stderr, res.stderr
    assert not (tmp_path / "x.h5").exists()


def test_segment_preset_study_builds_two_models(tmp_path):
    text = BASE + '[study.grid]\nsegment.preset = ["coarse", "default"]\n' \
        'contacts.shroud.angle_deg = [20.0, 80.0]\n'
    out = tmp_path / "preset.h5"
    res = wheelrom("study", toml(tmp_path, text), "--out", out, "--stability-only", "--json")
    summary = json.loads(res.stdout)
    assert summary["models"] == 2 and summary["mode"] == "stability"
    with h5py.File(out, "r") as f:
        assert f["cases/model"][()].tolist() == [0, 0, 1, 1]
        presets = [json.loads(f[f"models/{g}"].attrs["info"])["preset"] for g in (0, 1)]
        assert presets == ["coarse", "default"]
        assert "max_tip_amplitude" not in f["cases"]  # stability only: no transient datasets


def test_info_and_figures_of_a_stability_map(tmp_path):
    out = tmp_path / "map.h5"
    wheelrom("study", toml(tmp_path, ANGLES), "--out", out, "--stability-only")
    info = json.loads(wheelrom("info", out, "--json").stdout)
    assert info["kind"] == "study" and info["shape"] == [2, 4]
    assert info["counts"] == {"done": 0, "failed": 0, "pending": 0, "skipped": 8, "total": 8}
    assert sum(info["verdicts"].values()) == 8
    assert info["cases"][5]["parameters"] == {"contacts.tieboss.angle_deg": "60.0",
                                              "contacts.shroud.angle_deg": "30"}
    assert {"study_growth_rate.png", "study_min_normal_force_shroud.png",
            "stability_map_2d.png"} <= figures(out, tmp_path / "fig")
    res = wheelrom("export", out, "--csv", tmp_path / "x", check=False)
    assert res.returncode == 2 and "a --stability-only study: no transient to export" in res.stderr


def test_export_reads_study_files(mixed, tmp_path):
    _, n1, _ = mixed
    wheelrom("export", n1, "--case", 5, "--csv", tmp_path / "c5", "--what", "windows")
    rows = np.loadtxt(tmp_path / "c5_windows.csv", delimiter=",", skiprows=1, ndmin=2)
    with h5py.File(n1, "r") as f:
        assert np.array_equal(rows[:, 0], f["cases/window_end"][()])
        assert np.array_equal(rows[:, 1], f["cases/max_tip_amplitude"][5])


def test_three_keys_draw_one_map_per_pair(mixed, tmp_path):
    _, n1, _ = mixed
    res = wheelrom("plot", n1, "--outdir", tmp_path / "fig")
    names = {os.path.basename(p) for p in res.stdout.split()}
    for pair in ("0_1", "0_2", "1_2"):
        assert {f"study_growth_rate_{pair}.png", f"study_final_amplitude_{pair}.png",
                f"study_open_fraction_shroud_{pair}.png"} <= names
    assert "fig10_amplitude.png" not in names  # not an angle sweep
    from wheelrom.plots.study import StudyData, _slice

    with h5py.File(n1, "r") as f:
        d = StudyData(f, str(n1))
    grid, note = _slice(d, 0, 1, d.growth)
    assert note == " at friction.static = 0.6"
    assert np.array_equal(grid, d.growth.reshape(2, 2, 2)[:, :, 0])


def test_one_key_study_draws_lines_and_the_format1_stability_figures(tmp_path):
    text = BASE + '[study.grid]\ncontacts.shroud.angle_deg = "0:90:45"\n'
    out = tmp_path / "line.h5"
    wheelrom("study", toml(tmp_path, text), "--out", out, "--stability-only")
    names = figures(out, tmp_path / "f")
    assert {"study_1d.png", "stability_map.png", "stability_verdict.png"} <= names


def test_format1_sweep_files_still_read(tmp_path):
    out = tmp_path / "v1.h5"
    wheelrom("sweep", SMALL, "--out", out, "--set", "sweep.shroud_angles_deg=[20.0, 80.0]")
    info = json.loads(wheelrom("info", out, "--json").stdout)
    assert info["format"] == "wheelrom-sweep-1" and info["counts"]["done"] == 2
    names = figures(out, tmp_path / "f")
    assert "fig10_amplitude.png" in names and not any(n.startswith("study_") for n in names)


def test_a_time_step_study_runs_each_step_and_resumes(tmp_path):
    text = BASE + "[study.grid]\ntime.step = [5e-6, 1e-5]\n"
    cfg, out = toml(tmp_path, text), tmp_path / "steps.h5"
    wheelrom("study", cfg, "--out", out)
    with h5py.File(out, "r+") as f:
        steps = f["cases/steps"][()].tolist()
        assert [json.loads(o)["ts_dt"] for o in f["cases/options"][()]] == [5e-6, 1e-5]
        f["cases/status"][1] = b"pending"
    assert steps == [400, 200]  # 2 ms at each step
    wheelrom("study", cfg, "--out", out, "--resume")  # the other step is no mix-up
    with h5py.File(out, "r") as f:
        assert f["cases/status"][1] == b"done" and f["cases/steps"][1] == 200


def test_a_model_that_fails_on_rank_1_stops_every_rank_with_one_line(tmp_path):
    text = BASE + "[study.grid]\ncontacts.shroud.height = [2.18, 3.5]\n"
    out = tmp_path / "bad.h5"
    res = wheelrom("study", toml(tmp_path, text), "--out", out, "--stability-only", ranks=2,
                   check=False)
    assert res.returncode != 0
    lines = [line for line in res.stderr.splitlines() if line.startswith("wheelrom:")]
    assert lines == ["wheelrom: model 2 (case 1: shroud.height=3.5): contacts.shroud.height = "
                     "3.5 m is outside the built-in blade (1.1..2.2 m)"]
    assert not out.exists()
