"""The rough edges of issue #40: each small, each a surprise to a user. `config check`
refuses what `study` refuses; a byte-order mark is not part of a key; a FIFO, a directory
or a text file named as a mesh is told for what it is; a key pointing at the wrong file
does not print that file's lines."""

import os

import pytest

from conftest import HANG_S
from wheelrom.cli import main as cli

SECRET = "root:x:0:0:root:/root:/bin/bash"


def _write(path, text: str | bytes) -> str:
    mode = "wb" if isinstance(text, bytes) else "w"
    with open(path, mode) as fh:
        fh.write(text)
    return str(path)


def _one_error(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    return err


@pytest.fixture
def empty_toml(tmp_path):
    return _write(tmp_path / "empty.toml", "[segment]\npreset = 'coarse'\n")


def test_config_check_refuses_what_study_refuses(tmp_path, capsys):
    grid = "[study.grid]\n'contacts.shroud.angle_deg' = "
    toml = _write(tmp_path / "st.toml", grid + "[30.0, 120.0]\n")
    assert cli.main(["config", "check", toml]) == 2
    err = _one_error(capsys)
    assert "angle_deg[1]" in err and "must be <= 90" in err, err
    good = _write(tmp_path / "ok.toml", grid + "[30.0, 60.0]\n")
    assert cli.main(["config", "check", good]) == 0
    assert "study: 2 case(s) of contacts.shroud.angle_deg" in capsys.readouterr().out


def test_a_byte_order_mark_is_not_part_of_the_first_key(tmp_path, empty_toml, capsys):
    _write(tmp_path / "bom.csv", b"\xef\xbb\xbfcontacts.shroud.angle_deg\n30\n60\n")
    assert cli.main(["config", "check", empty_toml, "--set", 'study.cases="bom.csv"']) == 0
    assert "2 case(s)" in capsys.readouterr().out
    toml = _write(tmp_path / "bom.toml", b"\xef\xbb\xbf[time]\nend = 0.1\n")
    assert cli.main(["config", "show", toml]) == 0
    assert "end = 0.1" in capsys.readouterr().out
    _write(tmp_path / "pattern.csv", b"\xef\xbb\xbf" + b"0.01\n" * 66)
    assert cli.main(["config", "check", empty_toml, "--set", 'mistuning.file="pattern.csv"']) == 0


@pytest.mark.parametrize("kind", ["fifo", "directory", "device"])
def test_a_mesh_that_is_not_a_regular_file_says_so(kind, tmp_path, empty_toml, capsys):
    path = str(tmp_path / "seg.inp")
    if kind == "fifo":
        os.mkfifo(path)  # reading it would block forever
    elif kind == "directory":
        os.mkdir(path)
    else:
        path = "/dev/zero"
    assert cli.main(["config", "check", empty_toml, "--set", f'segment.source="{path}"']) == 2
    err = _one_error(capsys)
    assert "not a regular file" in err and path in err and "not found" not in err, err


def test_a_text_file_as_mesh_is_one_line(tmp_path, empty_toml, capsys):
    _write(tmp_path / "seg.inp", SECRET + "\n")
    assert cli.main(["config", "check", empty_toml, "--set", 'segment.source="seg.inp"']) == 2
    err = _one_error(capsys)
    assert "no nodes" in err and SECRET not in err, err


@pytest.mark.parametrize("key, extra, words", [
    ("study.cases", [], ["column 1", "31-character text"]),
    ("flutter.table", ["--set", 'flutter.model="table"'], ["unknown column", "31-character"]),
    ("mistuning.file", [], ["value 1", "31-character text"]),
])
def test_a_wrong_file_is_not_echoed(key, extra, words, tmp_path, empty_toml, capsys):
    _write(tmp_path / "secret.txt", SECRET + "\n" + "daemon:x:1:1::/usr/sbin:/bin/false\n")
    assert cli.main(["config", "check", empty_toml, "--set", f'{key}="secret.txt"', *extra]) == 2
    err = _one_error(capsys)
    assert SECRET not in err and "root:x" not in err and "daemon" not in err, err
    assert all(w in err for w in words), err


def test_config_show_writes_file_keys_that_work_anywhere(tmp_path, capsys, monkeypatch):
    """`config show sub/x.toml > y.toml` and a results file's stored configuration name the
    files the configuration meant, wherever they are read (animate from another folder)."""
    import h5py

    from wheelrom import config
    from wheelrom.results.layout import read_config

    sub = tmp_path / "sub"
    sub.mkdir()
    _write(sub / "pattern.txt", "0.01\n" * 66)
    _write(sub / "x.toml", "[segment]\npreset = 'coarse'\n[mistuning]\nfile = 'pattern.txt'\n")
    monkeypatch.chdir(tmp_path)
    assert cli.main(["config", "show", "sub/x.toml"]) == 0
    _write(tmp_path / "y.toml", capsys.readouterr().out)
    assert f'file = "{sub / "pattern.txt"}"' in (tmp_path / "y.toml").read_text()
    assert cli.main(["config", "check", "y.toml"]) == 0
    # a results file written from tmp_path, read from another folder
    cfg = config.load("sub/x.toml")
    with h5py.File(tmp_path / "r.h5", "w") as f:
        f.attrs["config"] = config.to_toml(cfg)
        f.attrs["config_source"] = cfg.source  # relative: sub/x.toml
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    with h5py.File("../r.h5", "r") as f:
        again = read_config(f, "../r.h5")
    assert again.mistuning.file == str(sub / "pattern.txt")


def test_copy_paste_hints_survive_a_shell(tmp_path, capsys):
    """The --resume line and the CalculiX line are shell-quoted: pasted, they name the files
    they meant (a space, a quote)."""
    import shlex

    from wheelrom.results.info import resume_hint

    path, source = "my runs/it's.h5", "cases dir/my study.toml"
    hint = resume_hint(path, source, {"pending": 2, "failed": 0}, "study", " --screen")
    words = shlex.split(hint[hint.index(": wheelrom") + 2 :])
    assert words == ["wheelrom", "study", source, "--out", path, "--screen", "--resume"], hint
    folder = tmp_path / "a b"
    folder.mkdir()
    out = folder / "seg x.inp"
    assert cli.main(["mesh", "--set", "segment.preset='coarse'", "--out", str(out)]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if "ccx -i" in ln)
    command = line[line.index("(") + 1 : line.rindex(")")]
    assert shlex.split(command) == ["cd", str(folder), "&&", "ccx", "-i", "seg x_cyclic"], line


@pytest.mark.parametrize("argv, words", [
    (["animate", "r.h5", "--scale", "-1"], ["--scale", "finite number > 0, got -1"]),
    (["animate", "r.h5", "--scale", "nan"], ["--scale", "got nan"]),
    (["accuracy", "--modes", "10", "-2"], ["--modes", "at least 1, got -2"]),
    (["accuracy", "--families", "0"], ["--families", "at least 1"]),
    (["modes", "--full-wheel", "assembled", "--full-wheel-modes", "0"],
     ["--full-wheel-modes", "at least 1"]),
])
def test_counts_and_scales_out_of_range_are_refused(argv, words, capsys, monkeypatch):
    def computed(*_):
        raise AssertionError("computed before the refusal")

    monkeypatch.setattr("wheelrom.segment.load.build_builtin", computed)
    with pytest.raises(SystemExit) as stop:
        cli.main(argv)
    assert stop.value.code == 2
    err = _one_error(capsys)
    assert all(w in err for w in words), err


def test_python_dash_m_wheelrom_is_the_command():
    import subprocess
    import sys

    res = subprocess.run([sys.executable, "-m", "wheelrom", "--version"], capture_output=True,
                         text=True, timeout=HANG_S)
    assert res.returncode == 0 and res.stdout.startswith("wheelrom "), res.stderr[-500:]


def test_plot_of_a_file_with_nothing_to_draw_is_refused(tmp_path, capsys):
    import h5py

    path = tmp_path / "bare.h5"
    with h5py.File(path, "w") as f:
        f.attrs["config"] = "[time]\nend = 0.1\n"
    assert cli.main(["plot", str(path)]) == 2
    assert "nothing to draw" in _one_error(capsys)
    assert not (tmp_path / "bare_figures").exists()  # no empty folder left behind


def test_campbell_refuses_to_replace_its_figure_before_computing(tmp_path, capsys,
                                                                 monkeypatch):
    def computed(*_, **__):
        raise AssertionError("computed before the refusal")

    monkeypatch.setattr("wheelrom.rom.campbell.campbell", computed)
    (tmp_path / "campbell.png").write_bytes(b"mine")
    assert cli.main(["campbell", "--outdir", str(tmp_path)]) == 2
    assert "campbell.png" in _one_error(capsys)
    assert (tmp_path / "campbell.png").read_bytes() == b"mine"


def test_resume_compares_values_not_the_help_text():
    """A file written by a wheelrom whose help texts (TOML comments) differ is the same
    configuration for --resume; a changed value is named with both values (the paper's
    pipeline refused its own finished sweep after a help text changed)."""
    from wheelrom import config
    from wheelrom.results.layout import config_changes

    cfg = config.load(None, ["time.end=0.5"])
    text = config.to_toml(cfg)
    older = "\n".join(line.split("#")[0].rstrip() + ("  # an older help" if "=" in line else "")
                      for line in text.splitlines())
    assert older != text and config_changes(older, cfg) is None
    changed = config_changes(older, config.load(None, ["time.end=0.6"]))
    assert changed == "time.end: 0.5 -> 0.6", changed
    assert "not TOML" in config_changes("= nonsense", cfg)


@pytest.mark.parametrize("given", ["toml", "set"])
def test_a_huge_value_is_quoted_cut(given, tmp_path, capsys):
    """A 1 MB string pasted into a key comes back as its first characters and its length, in
    a line of ordinary size (a 50 MB one was echoed whole to stderr), from a TOML file or
    from --set (which also names the configuration's source)."""
    from conftest import SMALL

    value = "a" * 1_000_000
    if given == "toml":
        argv = [_write(tmp_path / "big.toml", f'[wheel]\nbasis = "{value}"\n')]
    else:
        argv = [SMALL, "--set", f"wheel.basis={value}"]
    assert cli.main(["config", "check", *argv]) == 2
    err = _one_error(capsys)
    assert len(err) < 1000, err[:2000]
    assert "wheel.basis: 'aaaa" in err and "... (1000000 characters) is not one of" in err, err


def test_compare_refuses_a_run_larger_than_the_memory(capsys, monkeypatch):
    """`compare --steps 1000000000` samples 20 kHz over 5000 s: ~150 GB. One line with what it
    would need against what is available, exit 2, before the model is built (it was numpy's
    _ArrayMemoryError traceback, allocating 30 GiB for the sample buffers)."""
    from conftest import SMALL

    def built(*_, **__):
        raise AssertionError("built before the refusal")

    monkeypatch.setattr("wheelrom.rom.build.build_model", built)
    monkeypatch.setattr("wheelrom.runtime.environment.available_memory", lambda: 8 * 10**9,
                        raising=False)
    assert cli.main(["compare", SMALL, "--steps", "1000000000"]) == 2
    err = _one_error(capsys)
    assert len(err.splitlines()) == 1, err
    assert err.startswith("wheelrom: compare --steps 1000000000 would need about "), err
    assert "GB of memory" in err and "8.0 GB is available" in err, err


def test_the_memory_estimate_holds_the_context_it_allocates(small_model, small_cfg):
    """The estimate counts the context as allocated (to its alignment) and more beside it."""
    from wheelrom.forces.parameters import force_parameters
    from wheelrom.runtime.environment import petsc
    from wheelrom.transient.layout import context_bytes
    from wheelrom.transient.problem import WheelProblem
    from wheelrom.transient.run import run_bytes
    from wheelrom.transient.ts import time_grid

    grid = time_grid(small_cfg)
    problem = WheelProblem(small_model, small_cfg, [force_parameters(small_model, small_cfg)],
                           petsc().COMM_SELF, grid.sample_capacity, grid.state_capacity)
    try:
        allocated = problem.context.array.nbytes
    finally:
        problem.destroy()
    N, m, K = small_model.blades, small_model.modes, len(small_cfg.contacts.enabled_kinds())
    estimate = context_bytes(N, m, K, 1, grid.sample_capacity, grid.state_capacity)
    assert allocated <= estimate <= allocated + 8 * 8 * 60
    assert run_bytes(small_cfg) > estimate + 8 * 2 * grid.sample_capacity * 3 * N


def test_resume_of_a_file_from_before_a_new_key():
    """A file written before a key existed (here `forced.harmonics`, added after the paper's
    sweep file was written: ./run/paper's --resume refused it) is the same configuration while
    the key keeps its default; set to another value, the key is named."""
    from wheelrom import config
    from wheelrom.results.layout import config_changes

    cfg = config.load(None, ["time.end=0.5"])
    lines = config.to_toml(cfg).splitlines()
    section = ""
    kept = []
    for line in lines:
        section = line if line.startswith("[") else section
        if not (section == "[forced]" and line.startswith("harmonics")):
            kept.append(line)
    older = "\n".join(kept)
    assert older != config.to_toml(cfg) and config_changes(older, cfg) is None
    changed = config_changes(older, config.load(None, ["time.end=0.5", "forced.harmonics=9"]))
    assert changed == "forced.harmonics: '(none)' -> 9", changed
