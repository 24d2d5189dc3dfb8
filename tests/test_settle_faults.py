"""``wheelrom settle`` (and ``run``) when things go wrong (issue #47b): a disk that fills keeps
what was computed in $TMPDIR and names every path, leaving no partial file; Ctrl-C names the
finished cases kept beside the output and the --resume line; a ``[settle]`` whose times
cannot work is one line before anything is integrated; no NaN reaches a progress line or a
figure's warnings.

Small and fast: the small wheel as a Van der Pol wheel (tests/conftest.py), windows of two
periods (17 ms), a few windows per case."""

import io
import sys

import pytest

from conftest import SMALL, VDP_WHEEL
from wheelrom.cli import main as cli

#: one case, two-period windows, at most 0.05 s simulated
QUICK = [*VDP_WHEEL, "sweep.shroud_angles_deg=[50.0]", "settle.window_periods=2",
         "settle.min_time=0.05", "settle.max_time=0.05"]  # fmt: skip


def _sets(keys: list[str]) -> list[str]:
    return sum((["--set", k] for k in keys), [])


def _errors(err: str) -> list[str]:
    """The CLI's error lines (its warnings apart)."""
    return [ln for ln in err.splitlines()
            if ln.startswith("wheelrom:") and not ln.startswith("wheelrom: warning:")]  # fmt: skip


# --- 5: no NaN in a progress line, no warning from a figure ---------------------------


@pytest.fixture(scope="module")
def quick_settle(tmp_path_factory):
    """``(file, stderr)`` of one quick settle with every progress line shown (unthrottled)."""
    from wheelrom.cli import settle as cli_settle
    from wheelrom.cli.output import log

    out = tmp_path_factory.mktemp("quick") / "s.h5"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(cli_settle, "throttled", lambda every_s: log)
        err = io.StringIO()
        patch.setattr(sys, "stderr", err)
        assert cli.main(["settle", SMALL, *_sets(QUICK), "--out", str(out)]) == 0
    return out, err.getvalue()


def test_the_first_window_is_named_not_a_nan_percentage(quick_settle):
    _, err = quick_settle
    windows = [ln for ln in err.splitlines() if "largest blade" in ln and " um, " in ln]
    assert len(windows) >= 2, err
    assert "nan" not in err.lower(), err
    assert windows[0].endswith("first window"), windows[0]
    assert "window change" in windows[1], windows[1]


@pytest.mark.filterwarnings("error")  # a leaked RuntimeWarning fails the test
def test_plot_of_a_settle_file_warns_nothing(quick_settle, tmp_path, capsys):
    out, _ = quick_settle
    assert cli.main(["plot", str(out), "--outdir", str(tmp_path)]) == 0
    assert "Warning" not in capsys.readouterr().err
    assert (tmp_path / "settle_case0.png").exists()


# --- 4: [settle] times that cannot work: one line before anything is integrated ----------


def test_min_time_above_max_time_is_refused_naming_both(capsys):
    keys = [*QUICK, "settle.min_time=0.5", "settle.max_time=0.3"]
    for command in ("config check", "settle"):  # refused as every configuration error is
        assert cli.main([*command.split(), SMALL, *_sets(keys)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("wheelrom: invalid configuration:\n") and "Traceback" not in err
        (problem,) = err.splitlines()[1:]
        assert problem.endswith(": settle.min_time = 0.5 s is above settle.max_time = 0.3 s: "
                                "no case could ever be called settled"), problem  # fmt: skip


def test_max_time_shorter_than_one_window_is_refused_before_integrating(capsys, monkeypatch):
    """Two periods of the ND 6 flutter at 125 Hz are 16 ms: a 5 ms maximum holds no window
    (it was reported "not settled after 0 s", exit 0). The start (the preloaded equilibrium)
    gives the frequency; no window is integrated."""
    from wheelrom.transient import run

    def integrated(*_, **__):
        raise AssertionError("a window was integrated: the refusal came too late")

    monkeypatch.setattr(run, "run_case", integrated)
    keys = [*QUICK, 'settle.start="preload"', "settle.min_time=0.0", "settle.max_time=0.005"]
    assert cli.main(["settle", SMALL, *_sets(keys)]) == 2
    (line,) = _errors(capsys.readouterr().err)
    assert line.startswith("wheelrom: settle.max_time = 0.005 s is shorter than one window: "
                           "settle.window_periods = 2 periods"), line  # fmt: skip
