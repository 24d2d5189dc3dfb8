"""Every bad input one line, one rule per kind (issue #72): what sizes an allocation is
checked against the memory (or a cap) before anything is computed; every numeric key and
option has a physical range and the configuration's caps apply to the options that set a
key; ``--set`` of a whole table is merged into its section; no numpy ``RuntimeWarning``
reaches the user; a message names the key or option the user gave."""

import subprocess
import sys

import pytest

from conftest import SMALL
from wheelrom.cli import main as cli


@pytest.fixture
def nothing_computed(monkeypatch):
    """Fails the test if a segment is built or read (every computation starts there)."""
    def computed(*_):
        raise AssertionError("a segment was built: the refusal came too late")

    monkeypatch.setattr("wheelrom.segment.load.build_builtin", computed)
    monkeypatch.setattr("wheelrom.segment.load.read_segment", computed)


@pytest.fixture
def eight_gb(monkeypatch):
    """8 GB of memory available, whatever the machine has."""
    monkeypatch.setattr("wheelrom.runtime.environment.available_memory", lambda: 8 * 10**9)


def _refused(capsys, argv, words, absent=()):
    """``argv`` exits 2 with the words in its message (one ``wheelrom:`` line, or a
    configuration's problem lines), no traceback, no warning, none of ``absent``."""
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "Warning" not in err, err[:3000]
    assert err.startswith("wheelrom: ") and len(err) < 1000, err[:3000]
    for word in words:
        assert word in err, err
    for word in absent:
        assert word not in err, err
    return err


# --- rule 3: --set of a whole table is merged ------------------------------------------


def test_set_of_a_table_merges_into_its_section(tmp_path):
    """Item 14: ``--set 'time={end=1.0}'`` replaced [time]: scheme, step and window went
    back to their defaults. A table merges key by key, nested tables too."""
    from wheelrom import config

    cfg = config.load(SMALL, ["time={end=1.0}"])
    assert (cfg.time.end, cfg.time.scheme, cfg.time.step, cfg.time.window) == \
        (1.0, "rk", 5e-6, 5e-4)
    toml = tmp_path / "c.toml"
    toml.write_text(open(SMALL).read() + "\n[contacts.shroud]\nnormal_preload = 300.0\n"
                    '[study.grid]\n"contacts.shroud.angle_deg" = [20.0, 50.0]\n')
    cfg = config.load(toml, ["contacts={shroud={angle_deg=30.0}}",
                             'study.grid={"contacts.tieboss.angle_deg"=[40.0]}'])
    assert (cfg.contacts.shroud.angle_deg, cfg.contacts.shroud.normal_preload) == (30.0, 300.0)
    assert cfg.contacts.shroud.height == 2.18  # the shroud's own default, not the tie-boss's
    assert dict(cfg.study.grid) == {"contacts.shroud.angle_deg": (20.0, 50.0),
                                    "contacts.tieboss.angle_deg": (40.0,)}
    # a value replaced by a later --set of its table, in order
    assert config.load(SMALL, ["time.end=0.5", "time={end=0.25}"]).time.end == 0.25


# --- rule 4: no numpy RuntimeWarning reaches the user ------------------------------------

#: forced-response --nonlinear with the nozzle force of issue #72 (1e30 N) put past the range
#: check: the balance overflows in numpy ("invalid value encountered in subtract")
HUGE_FORCE = """
import dataclasses, sys
from wheelrom.cli import main as cli
from wheelrom.studies import forced_nonlinear
real = forced_nonlinear.forced_inputs
def huge(*args, **kwargs):
    params, q = real(*args, **kwargs)
    return dataclasses.replace(params, nozzle_force=1e30), q
forced_nonlinear.forced_inputs = huge
sys.exit(cli.main(["forced-response", sys.argv[1], "--nonlinear", "--frequencies",
                   "118:120:3"]))
"""


def test_numpy_runtime_warnings_never_reach_stderr():
    """Item 12: raw ``RuntimeWarning`` lines with numpy's source lines were printed; the
    command's own line says what failed ("no solution")."""
    done = subprocess.run([sys.executable, "-c", HUGE_FORCE, SMALL], capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Warning" not in done.stderr, done.stderr[-3000:]
    unsolved = [line.split()[0] for line in done.stdout.splitlines()
                if line.split()[2:] == ["no", "solution"]]
    assert unsolved == ["118.0000", "119.0000", "120.0000"], done.stdout


