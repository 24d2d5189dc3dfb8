"""Configuration: defaults = Table 1, parsing, every validation rule, --set overrides, CLI."""

import subprocess
import sys

import pytest

from wheelrom import config
from wheelrom.cli.main import main


def write(tmp_path, text, name="case.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_defaults_are_table_1():
    c = config.load()
    assert (c.wheel.blades, c.wheel.stator_vanes, c.wheel.speed_hz) == (66, 64, 50.0)
    assert (c.flutter.r, c.flutter.mu, c.wheel.damping_beta) == (5e-3, 100.0, 5e-8)
    f = c.friction
    assert (f.static, f.dynamic, f.decay, f.microslip_velocity) == (0.6, 0.4, 2.0, 0.6)
    t = c.contacts.tieboss
    assert (t.normal_preload, t.height, t.angle_deg, t.stiffness) == (400.0, 1.6, 45.0, 7.6e7)
    assert (t.arm_length, t.profile_thickness) == (0.15, 3.1e-2)
    s = c.contacts.shroud
    assert (s.normal_preload, s.height, s.arm_length, s.profile_thickness) == (
        400.0,
        2.18,
        0.2,
        3.46e-2,
    )
    assert c.wheel.coupling_stiffness == 2e8 and c.wheel.modes_per_segment == 10
    assert (c.time.step, c.time.window, c.time.end) == (1e-5, 0.0375, 1.5)
    assert c.time.scheme == "exponential"  # issue #31: the paper's RK3 is time.scheme = 'rk'
    assert c.sweep.tieboss_angles_deg == (45.0,)
    assert c.sweep.shroud_angles_deg == tuple(float(a) for a in range(0, 91, 5))


def test_paper_toml_equals_defaults():
    assert config.load("run/paper.toml") == config.load()


def test_round_trip_through_toml(tmp_path):
    c = config.load(overrides=["contacts.shroud.stiffness=[[0.0, 1e9], [90.0, 2e7]]"])
    again = config.load(write(tmp_path, config.to_toml(c)))
    assert again == c
    assert again.contacts.shroud.stiffness == ((0.0, 1e9), (90.0, 2e7))


def test_partial_section_keeps_other_defaults(tmp_path):
    c = config.load(write(tmp_path, "[contacts.shroud]\nangle_deg = 20\n"))
    assert c.contacts.shroud.angle_deg == 20.0 and c.contacts.shroud.height == 2.18
    assert c.contacts.tieboss.height == 1.6


def test_set_overrides_types():
    c = config.load(
        overrides=[
            "time.end=0.2",
            "contacts.shroud.enabled=false",
            "segment.source=my mesh.msh",
            "sweep.shroud_angles_deg=[10, 20]",
        ]
    )
    assert c.time.end == 0.2 and c.contacts.shroud.enabled is False
    assert c.segment.source == "my mesh.msh"
    assert c.sweep.shroud_angles_deg == (10.0, 20.0)
    assert c.contacts.enabled_kinds() == ["tieboss"]


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("[wheel]\nbladse = 66\n", "wheel.bladse: unknown key (did you mean 'blades'?)"),
        ("[wheeel]\nblades = 66\n", "wheeel: unknown section (did you mean 'wheel'?)"),
        ("[time]\nstep = -1e-6\n", "time.step: must be >= 1e-09 s"),
        ("[time]\nstep = 0.1\nwindow = 0.01\n", "time.step: larger than time.window"),
        ("[time]\nend = nan\n", "time.end: must be finite"),
        ("[time]\nstart = 'warm'\n", "time.start: 'warm' is not one of"),
        ("[friction]\ndynamic = 0.7\n", "friction.dynamic: must not exceed friction.static"),
        ("[flutter]\nr = 0\n", "flutter.r: must be > 0.0"),
        ("[flutter]\nmode = 10\n", "flutter.mode: 10 is not below"),
        ("[wheel]\nblades = 2\n", "wheel.blades: must be >= 3"),
        ("[wheel]\nblades = 6.5\n", "wheel.blades: expected an integer"),
        ("[contacts.shroud]\nangle_deg = 95\n", "contacts.shroud.angle_deg: must be <= 90.0"),
        ("[contacts.tieboss]\nenabled = 1\n", "contacts.tieboss.enabled: expected true or false"),
        ("[contacts.tieboss]\nstiffness = 'soft'\n", "contacts.tieboss.stiffness: expected"),
        ("[contacts.tieboss]\nstiffness = [[50, 1e8], [40, 2e8]]\n", "angles must increase"),
        ("[sweep]\nshroud_angles_deg = [10, 100]\n", "sweep.shroud_angles_deg[1]: must be <="),
        ("[sweep]\nshroud_angles_deg = []\n", "sweep.shroud_angles_deg: expected a non-empty"),
        ("[segment]\npreset = 'fine'\n", "segment.preset: 'fine' is not one of"),
        ("[segment]\npoisson = 0.5\n", "segment.poisson: must be <= 0.4999"),
        ("[excitation]\nforce = -1\n", "excitation.force: must be >= 0.0"),
        ("[output]\nsample_rate_hz = 1e9\n", "output.sample_rate_hz"),
        ("[segment.node_sets]\ntip = [[1, 2]]\n", "segment.node_sets.tip: expected a list"),
    ],
)
def test_validation_rule(tmp_path, text, fragment):
    path = write(tmp_path, text)
    with pytest.raises(config.ConfigError) as err:
        config.load(path)
    message = str(err.value)
    assert fragment in message
    assert str(path) in message


def test_not_toml_and_missing_file(tmp_path):
    with pytest.raises(config.ConfigError, match="not valid TOML"):
        config.load(write(tmp_path, "[wheel\n"))
    with pytest.raises(config.ConfigError, match="file not found"):
        config.load(tmp_path / "nope.toml")


def test_check_names_all_three_problems_and_exits_2(tmp_path, capsys):
    path = write(tmp_path, "[wheel]\nbladse = 66\n[time]\nstep = -1\n[friction]\ndynamic = 0.9\n")
    assert main(["config", "check", str(path)]) == 2
    err = capsys.readouterr().err
    for key in ("wheel.bladse", "time.step", "friction.dynamic"):
        assert key in err
    assert err.count(str(path)) == 3


def test_cli_show_and_help():
    out = subprocess.run(
        [sys.executable, "-m", "wheelrom.cli.main", "config", "show", "--set", "time.end=0.25"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert "end = 0.25" in out.stdout
    for args in (["--help"], ["config", "check", "--help"]):
        res = subprocess.run(
            [sys.executable, "-m", "wheelrom.cli.main", *args], capture_output=True, text=True
        )
        assert res.returncode == 0 and "usage" in res.stdout
