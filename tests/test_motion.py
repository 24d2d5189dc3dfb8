"""Output that scales and looking at a case: the tip history at output.history_rate_hz, the
modal state history at output.state_rate_hz (it changes no result), the wheel surface in
XDMF against the model's own tip, contact forces from the state history against the
solver's monitor, and the animate / contacts / export commands."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from conftest import HANG_S, SMALL
from wheelrom import config
from wheelrom.cli import main as cli
from wheelrom.config import ConfigError

ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1")
WHEELROM = [sys.executable, "-m", "wheelrom.cli.main"]
STATE = ["--set", "output.state_rate_hz=20000"]  # every statistics sample


@pytest.mark.parametrize("key", ["history_rate_hz", "state_rate_hz"])
def test_history_rates_must_divide_the_sample_rate(key):
    with pytest.raises(ConfigError, match=f"output.{key}: 3000 Hz is not output.sample_rate_hz"):
        config.load(SMALL, [f"output.{key}=3000"])
    for ok in ("0", "2000", "20000", "50000"):  # off, 20000 / 10, every sample, capped
        config.load(SMALL, [f"output.{key}={ok}"])


def test_time_grid_counts_history_samples():
    from wheelrom.transient.ts import time_grid

    grid = time_grid(config.load("run/paper.toml"))
    assert grid.samples_max == 30002 and grid.history_every == 10 and grid.history_max == 3001
    assert grid.state_every == 0 and grid.state_max == 0
    off = time_grid(config.load("run/paper.toml", ["output.history_rate_hz=0"]))
    assert off.history_every == 0 and off.history_max == 0


def test_paper_layouts_fit(coarse_model):
    """The paper sweep's preallocated size before (tip history at 20 kHz) and after (2 kHz);
    a 19 x 19 angle map of 1.5 s stays under 2 GB at the default history rate."""
    from wheelrom.results.histories import case_bytes
    from wheelrom.results.layout import create_layout

    def size(*overrides):
        cfg = config.load("run/paper.toml", list(overrides))
        with h5py.File("layout.h5", "w", driver="core", backing_store=False) as f:
            create_layout(f, cfg, coarse_model)  # 66 blades x 10 modes, the paper's size
            return sum(case_bytes(f["cases"]).values()) * f["cases/status"].shape[0]

    before = size("output.history_rate_hz=20000")
    after = size()
    assert 900e6 < before < 920e6 and 85e6 < after < 95e6
    angles = "[" + ", ".join(str(5.0 * k) for k in range(19)) + "]"
    assert size(f"sweep.tieboss_angles_deg={angles}") < 2e9
    state = size("output.state_rate_hz=2000") - after
    assert state == 19 * 3001 * 2 * 66 * 10 * 8 + 19 * (3001 + 1) * 8


def test_a_parallel_file_allocates_what_info_reports(coarse_model, tmp_path):
    """A parallel (mpio) file is allocated in full at creation: its size is the bytes per
    case times the cases, within 1 % (chunks split the samples evenly) plus /model."""
    from mpi4py import MPI

    from wheelrom.results.histories import case_bytes
    from wheelrom.results.layout import create_layout

    path = tmp_path / "paper.h5"
    with h5py.File(path, "w", driver="mpio", comm=MPI.COMM_SELF) as f:
        create_layout(f, config.load("run/paper.toml"), coarse_model)
        logical = sum(case_bytes(f["cases"]).values()) * 19
        assert f["cases/tip_history"].chunks == (1, 601, 66, 3)  # 3001 = 5 x 601 - 4
    assert logical < os.path.getsize(path) < 1.01 * logical + 1e6


def test_state_history_changes_no_result(small_model, small_cfg):
    """Recording the modal state leaves every result bitwise as it was, alone and in a
    batch, and its tip at the shared sample times is the tip history."""
    from wheelrom.transient.run import run_case, run_cases

    angles = [{"shroud": 20.0}, {"shroud": 50.0}]
    plain = run_case(small_model, small_cfg, angles[1])
    cfg = small_cfg.replace(**{"output.state_rate_hz": 10000.0, "output.history_rate_hz": 0})
    both = run_cases(small_model, cfg, angles)
    with_state = both[1]
    for name in ("max_tip_amplitude", "nd_spectrum", "energy", "work", "final_state"):
        assert np.array_equal(getattr(plain, name), getattr(with_state, name)), name
    for kind in plain.min_normal_force:
        assert np.array_equal(plain.min_normal_force[kind], with_state.min_normal_force[kind])
    assert with_state.tip_history.size == 0 and plain.tip_history.shape == (5, 12, 3)
    alone = run_case(small_model, cfg.replace(**{"output.history_rate_hz": 2000.0}), angles[1])
    assert np.array_equal(alone.tip_history, plain.tip_history)
    assert np.array_equal(alone.state_history, with_state.state_history)
    assert with_state.state_history.shape == (21, 2, 12, 6)
    assert np.allclose(with_state.state_time, np.arange(21) * 1e-4, atol=5e-6)
    tip = np.einsum("ksm,am->ksa", alone.state_history[::5, 0], small_model.tip)
    scale = np.abs(plain.tip_history).max()
    assert np.abs(tip - plain.tip_history).max() <= 1e-12 * scale


@pytest.fixture(scope="module")
def case_file(tmp_path_factory):
    """``run --out`` of the small wheel (shroud 50 deg, 2 ms) with a state history at every
    statistics sample."""
    path = tmp_path_factory.mktemp("motion") / "case.h5"
    subprocess.run(WHEELROM + ["run", SMALL, *STATE, "--out", str(path)], env=ENV, check=True,
                   capture_output=True, timeout=HANG_S)
    return str(path)


def test_contact_forces_from_the_state_history_are_the_monitors(case_file):
    """Per window, the smallest normal force and the open fraction of the reconstructed
    contacts are what the compiled monitor recorded at the same samples."""
    from wheelrom.results.reconstruct import case_contacts

    histories = case_contacts(case_file, 0)
    with h5py.File(case_file, "r") as f:
        ends = f["cases/window_end"][()]
        recorded = {k: (f[f"cases/min_normal_force/{k}"][0], f[f"cases/open_fraction/{k}"][0])
                    for k in histories}
    assert set(histories) == {"tieboss", "shroud"}
    for kind, h in histories.items():
        window = np.searchsorted(ends + 2.5e-6, h.time)  # a sample at a window's end is its
        low = [h.normal_force[window == w].min() for w in range(ends.size)]
        opened = [(h.state[window == w] == 0).mean() for w in range(ends.size)]
        np.testing.assert_allclose(low, recorded[kind][0], rtol=0, atol=1e-9 * 400.0)
        np.testing.assert_array_equal(opened, recorded[kind][1])
        assert np.all(h.friction_force[h.state == 0] == 0.0)


# the small wheel (state history at every sample) as a study of two models x two frictions
STUDY = Path(SMALL).read_text().split("[sweep]")[0] + """state_rate_hz = 20000.0
[study.grid]
wheel.modes_per_segment = [4, 6]
friction.static = [0.6, 0.9]
"""


def test_contacts_of_a_study_case_use_its_own_model_and_parameters(tmp_path, capsys):
    """In a study file every case may have its own model (``/models/<g>``) and parameters:
    the contact forces rebuilt from case 3's state history (6 modes, static friction 0.9)
    are what its compiled monitors recorded, and ``contacts`` and ``export`` read them."""
    from wheelrom.results.reconstruct import case_contacts

    study, out = tmp_path / "study.toml", tmp_path / "study.h5"
    study.write_text(STUDY)
    subprocess.run(WHEELROM + ["study", str(study), "--out", str(out)], env=ENV, check=True,
                   capture_output=True, timeout=HANG_S)
    histories = case_contacts(str(out), 3)
    with h5py.File(out, "r") as f:
        assert f["cases/model"][3] == 1 and f["models/1"].attrs["modes"] == 6
        ends = f["cases/window_end"][()]
        recorded = {k: f[f"cases/min_normal_force/{k}"][3] for k in histories}
        other = f["cases/min_normal_force/shroud"][1]  # 4 modes, same friction
    for kind, h in histories.items():
        window = np.searchsorted(ends + 2.5e-6, h.time)
        low = [h.normal_force[window == w].min() for w in range(ends.size)]
        np.testing.assert_allclose(low, recorded[kind], rtol=0, atol=1e-9 * 400.0)
    assert np.abs(other - recorded["shroud"]).max() > 1e-6  # the groups differ: a real check
    assert cli.main(["contacts", str(out), "--case", "3", "--blade", "0",
                     "--out", str(tmp_path / "c")]) == 0
    assert cli.main(["export", str(out), "--case", "3", "--what", "contact_forces",
                     "--csv", str(tmp_path / "x")]) == 0
    rows = np.loadtxt(tmp_path / "x_contact_forces.csv", delimiter=",", skiprows=1, ndmin=2)
    np.testing.assert_array_equal(rows[:, 1], histories["tieboss"].normal_force[:, 0])
    assert cli.main(["animate", str(out), "--case", "3", "--out", str(tmp_path / "a")]) == 2
    assert "is a study file (format 'wheelrom-sweep-2'): animate reads the cases of a sweep" \
        in capsys.readouterr().err


def test_xdmf_holds_the_models_tip_motion(case_file, tmp_path, capsys):
    import meshio

    from wheelrom.results.histories import state_window
    from wheelrom.results.wheel_motion import rebuild
    from wheelrom.runtime.environment import petsc

    prefix = str(tmp_path / "wheel")
    assert cli.main(["animate", case_file, "--out", prefix, "--frames", "5"]) == 0
    assert capsys.readouterr().out.split() == [prefix + e for e in (".xdmf", ".h5", ".gif", ".png")]
    with h5py.File(case_file, "r") as f:
        wheel = rebuild(f, case_file, petsc().COMM_SELF)
        times, states = state_window(f["cases"], case_file, 0, (0.0015, 0.002))
    seg, model = wheel.segment.mesh, wheel.model
    with meshio.xdmf.TimeSeriesReader(prefix + ".xdmf") as reader:
        points, cells = reader.read_points_cells()
        assert reader.num_steps == 5 and cells[0].type == "quad"
        t, point_data, _ = reader.read_data(reader.num_steps - 1)
    assert t == times[-1]
    u = point_data["displacement"]
    N, P = model.blades, points.shape[0] // model.blades
    tip_node = seg.node_sets["tip"][0]
    first = np.flatnonzero(np.all(points[:P] == seg.nodes[tip_node], axis=1))
    assert first.size == 1
    for s in range(N):
        angle = 2 * np.pi * s / N
        R = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0],
                      [0, 0, 1]])
        expect = R @ (model.tip @ states[-1, 0, s])
        assert np.abs(u[s * P + first[0]] - expect).max() <= 1e-12 * np.abs(expect).max()
        assert np.allclose(points[s * P + first[0]], R @ seg.nodes[tip_node], rtol=0, atol=1e-12)


def test_animate_refuses_a_model_that_does_not_rebuild(case_file, tmp_path, capsys):
    changed = tmp_path / "changed.h5"
    shutil.copy(case_file, changed)
    with h5py.File(changed, "r+") as f:
        A0 = f["model/A0"][()]
        A0[0, 0] *= 1 + 1e-8
        f["model/A0"][...] = A0
    assert cli.main(["animate", str(changed), "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "differs from the stored /model/A0" in err and str(changed) in err
    assert not list(tmp_path.glob("x*"))


def test_contacts_figures_and_csv(case_file, tmp_path, capsys):
    from wheelrom.results.reconstruct import case_contacts

    prefix = str(tmp_path / "c")
    assert cli.main(["contacts", case_file, "--blade", "0", "5", "--kind", "shroud",
                     "--window", "0:0.002", "--out", prefix]) == 0
    written = capsys.readouterr().out.split()
    assert written == [f"{prefix}_normal_force.png", f"{prefix}_hysteresis_shroud_blade0.png",
                       f"{prefix}_hysteresis_shroud_blade5.png"]
    assert all(os.path.getsize(p) > 1000 for p in written)
    assert cli.main(["contacts", case_file, "--out", prefix, "--kind", "shroud"]) == 2
    assert "exists" in capsys.readouterr().err
    assert cli.main(["export", case_file, "--csv", prefix, "--what", "contact_forces"]) == 0
    csv = np.loadtxt(f"{prefix}_contact_forces.csv", delimiter=",", skiprows=1)
    h = case_contacts(case_file, 0)
    assert np.array_equal(csv[:, 0], h["tieboss"].time)
    assert np.array_equal(csv[:, 1:7], np.column_stack([
        h["tieboss"].normal_force[:, 0], *h["tieboss"].friction_force[:, 0].T,
        *h["tieboss"].relative_displacement[:, 0].T]))
    assert csv.shape[1] == 1 + 2 * 12 * 6


@pytest.mark.parametrize("argv, message", [
    (["animate", "{f}", "--case", "7"], "--case 7: the file has 1 case (0..0)"),
    (["contacts", "{f}", "--case", "-1"], "--case -1: the file has 1 case"),
    (["animate", "{f}", "--window", "0.2-0.3"], "--window 0.2-0.3: expected a:b in seconds"),
    (["animate", "{f}", "--window", "1:2"], "--window 1:2: no state history sample in it"),
    (["contacts", "{f}", "--blade", "12"], "--blade 12: the wheel has blades 0..11"),
    (["contacts", "{f}", "--kind", "rim"], "--kind rim: the case has contacts tieboss, shroud"),
    (["animate", "nosuch.h5"], "nosuch.h5: no such file"),
])
def test_bad_input_is_one_line(case_file, tmp_path, capsys, argv, message):
    argv = [a.format(f=case_file) for a in argv] + ["--out", str(tmp_path / "o")]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


@pytest.fixture(scope="module")
def tips_only(tmp_path_factory):
    path = tmp_path_factory.mktemp("tips") / "tips.h5"
    subprocess.run(WHEELROM + ["run", SMALL, "--out", str(path)], env=ENV, check=True,
                   capture_output=True, timeout=HANG_S)
    return str(path)


def test_without_a_state_history(tips_only, tmp_path, capsys):
    """``animate`` draws the tip ring from the tip history; ``contacts`` and the contact
    force export say how to get a state history."""
    prefix = str(tmp_path / "t")
    assert cli.main(["animate", tips_only, "--out", prefix]) == 0
    assert capsys.readouterr().out.split() == [prefix + ".gif"]
    from PIL import Image

    with Image.open(prefix + ".gif") as gif:
        assert gif.n_frames == 2  # the last window's tip history samples at 2 kHz: 1.5, 2 ms
    for argv in (["contacts", tips_only, "--out", prefix],
                 ["export", tips_only, "--csv", prefix, "--what", "contact_forces"]):
        assert cli.main(argv) == 2
        assert (f"{tips_only} has no state history: rerun with output.state_rate_hz > 0"
                in capsys.readouterr().err)


def test_info_reports_bytes_per_case(case_file, capsys):
    from wheelrom.results.info import file_info

    info = file_info(case_file)
    by = info["bytes_per_case_by_dataset"]
    # room for 42 samples (2 ms at 20 kHz + 2), every 10th for the tips
    assert by["state_history"] == 42 * 2 * 12 * 6 * 8 and by["tip_history"] == 5 * 12 * 3 * 8
    assert info["bytes_per_case"] == sum(by.values()) and info["file_bytes"] > 0
    assert cli.main(["info", case_file]) == 0
    assert "MB per case (state_history" in capsys.readouterr().out


def test_batched_mpi_sweep_records_the_same_states(tmp_path):
    """A sweep under mpirun -n 2 in batches of 2 and a serial one in batches of 1 store the
    same state histories, bitwise (with the chunked history datasets)."""
    runs = {}
    for name, ranks, batch in (("serial", 1, "1"), ("mpi", 2, "2")):
        out = tmp_path / f"{name}.h5"
        cmd = WHEELROM + ["sweep", SMALL, "--set", "output.state_rate_hz=5000", "--out",
                          str(out), "--batch", batch]
        if ranks > 1:
            cmd = ["mpirun", "-n", str(ranks), *cmd]
        subprocess.run(cmd, env=ENV, check=True, capture_output=True, timeout=HANG_S)
        with h5py.File(out, "r") as f:
            runs[name] = {k: f[f"cases/{k}"][()] for k in
                          ("state_history", "state_time", "states_done", "tip_history")}
            assert f["cases/state_history"].chunks[:2] == (1, 11)
    for key, value in runs["serial"].items():
        assert np.array_equal(value, runs["mpi"][key], equal_nan=True), key
    assert runs["serial"]["states_done"].tolist() == [11, 11, 11]


def test_animate_never_overwrites_its_results_file(case_file, capsys):
    """``--out`` equal to the file's stem would make PREFIX.h5 the results file: refused,
    even with --force."""
    before = os.path.getsize(case_file)
    stem = os.path.splitext(case_file)[0]
    assert cli.main(["animate", case_file, "--out", stem, "--force"]) == 2
    assert "would overwrite the results file" in capsys.readouterr().err
    assert os.path.getsize(case_file) == before
