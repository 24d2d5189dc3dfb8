"""Campbell command: prestressed frequencies versus speed, figure and JSON."""

import json

import numpy as np

from conftest import SMALL


def test_campbell_json_and_figure(tmp_path, capsys):
    from wheelrom.cli import main as cli

    argv = ["campbell", SMALL, "--set", "wheel.modes_per_segment=3", "--speeds", "0,30,60",
            "--outdir", str(tmp_path), "--json"]
    assert cli.main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    seg = np.array(out["segment_hz"])
    wheel = np.array(out["wheel_hz_by_nd"])
    assert seg.shape == (3, 3) and wheel.shape == (3, 7, 3)
    assert np.all(np.diff(seg[:, 0]) > 0)  # the first (flapwise) mode stiffens with speed
    png = tmp_path / "campbell.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 5000


def test_campbell_rejects_bad_speeds(capsys, tmp_path, monkeypatch):
    from wheelrom.cli import main as cli

    monkeypatch.chdir(tmp_path)  # the default --outdir out/figures does not exist yet

    assert cli.main(["campbell", SMALL, "--speeds", "0:x:3"]) == 2
    assert "--speeds" in capsys.readouterr().err
