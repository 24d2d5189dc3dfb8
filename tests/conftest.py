"""Shared fixtures: small models built once per session."""

import os

import pytest

from handshake import HANG_S  # noqa: F401 (every test's subprocess timeout, from here)
from wheelrom.runtime.environment import bootstrap

bootstrap()  # PETSc location and one BLAS thread per process, before numpy loads
os.environ.setdefault("MPLBACKEND", "Agg")
# every model built, none read from a cache of earlier runs (tests/test_model_cache.py checks
# the cache in a directory of its own)
os.environ["WHEELROM_MODEL_CACHE"] = "off"
HERE = os.path.dirname(__file__)
SMALL = os.path.join(HERE, "data", "small.toml")
#: the small wheel as a Van der Pol wheel alone: no contacts, (almost) no structural damping,
#: the relative law at mu = 10 (a smooth cycle; settle and monodromy tests start from it)
VDP_WHEEL = ["contacts.tieboss.enabled=false", "contacts.shroud.enabled=false",
             "wheel.damping_beta=1e-9", "flutter.mu=10.0", "flutter.r=1e-5",
             'flutter.model="relative"', 'time.scheme="exponential"', "time.step=1e-5"]


@pytest.fixture
def nothing_computed(monkeypatch):
    """Fails the test if a segment is built or read (every computation starts there): a
    refusal under it came before anything was computed."""
    def computed(*_):
        raise AssertionError("a segment was built: the refusal came too late")

    monkeypatch.setattr("wheelrom.segment.load.build_builtin", computed)
    monkeypatch.setattr("wheelrom.segment.load.read_segment", computed)


def one_error(capsys) -> str:
    """The one ``wheelrom:`` line a refused command wrote to stderr (no traceback)."""
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.startswith("wheelrom:")]
    assert len(lines) == 1, err
    return lines[0]


@pytest.fixture(scope="session")
def comm():
    """``PETSc.COMM_SELF``: the communicator of serial builds."""
    from wheelrom.runtime.environment import petsc

    return petsc().COMM_SELF


@pytest.fixture(scope="session")
def coarse_cfg():
    from wheelrom import config

    # the paper's basis, scheme and step: 10 free-interface modes, RK 3bs at 5 us (the tests'
    # reference sizes)
    return config.load(overrides=['segment.preset="coarse"', 'wheel.basis="free"',
                                  'time.scheme="rk"', "time.step=5e-6"])


@pytest.fixture(scope="session")
def coarse_segment(coarse_cfg):
    """The coarse built-in segment with its standstill matrices (no prestress)."""
    from wheelrom.segment import assembly, builtin

    seg = builtin.build_builtin(coarse_cfg)
    mats = assembly.assemble(seg, 2.1e11, 0.3, 7850.0)
    return seg, mats


@pytest.fixture(scope="session")
def coarse_model(coarse_cfg, comm):
    """66 blades x 10 modes on the coarse segment (the paper's ROM size)."""
    from wheelrom.rom.build import build_model

    return build_model(coarse_cfg, comm)


@pytest.fixture(scope="session")
def small_cfg():
    from wheelrom import config

    return config.load(SMALL)


@pytest.fixture(scope="session")
def small_model(small_cfg, comm):
    from wheelrom.rom.build import build_model

    return build_model(small_cfg, comm)


def one_mode_ring(blades: int, w0: float, coupling: float, contact_angle_deg: float,
                  contact_stiffness: float, preload: float, excitation: float = 0.0):
    """``(model, contacts)``: ``blades`` one-mode blades in a ring (unit modal mass; the mode
    moves the tip, the aerofoil and the profile points A, B by 1 m in ``y``), stiffness
    ``w0^2`` [N/m per kg] and a spring ``coupling`` to each neighbour, a contact between
    neighbours of frame ``contact_frame(contact_angle_deg)`` (0: its normal is ``y``, the
    gap follows the relative motion; 90: ``z``, the gap never changes), arm length 0 (A is
    the contact point), normal stiffness ``contact_stiffness`` [N/m] and ``preload`` [N];
    ``excitation``: the mode's generalised force per unit nozzle force."""
    import math

    import numpy as np

    from wheelrom.forces.parameters import ContactParameters, contact_frame
    from wheelrom.rom.model import ReducedModel

    y = np.array([[0.0], [1.0], [0.0]])
    points = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.03]])
    model = ReducedModel(
        blades=blades, modes=1, segment_hz=np.array([w0 / (2 * math.pi)]),
        K_seg=np.array([[w0**2]]), A0=np.array([[w0**2 + 2 * coupling]]),
        A1=np.array([[-coupling]]), rotation=np.eye(3), tip=y.copy(), aero=np.array([1.0]),
        excitation=np.array([excitation]), contact_A={"shroud": y.copy()},
        contact_B={"shroud": y.copy()}, contact_points={"shroud": points})
    contacts = ContactParameters(
        kinds=("shroud",), shape_A=y[None].copy(), shape_B=y[None].copy(),
        point_A=points[:1].copy(), point_B=points[1:].copy(), arm_length=np.array([0.0]),
        frame=np.broadcast_to(contact_frame(contact_angle_deg), (1, blades, 3, 3)).copy(),
        stiffness=np.full((1, blades), contact_stiffness), preload=np.array([preload]),
        angles_deg={"shroud": np.full(blades, contact_angle_deg)},
        tangential=np.zeros((1, blades)))
    return model, contacts


#: the suite's longest tests (90-20 s each on a 2-core machine: compiling every kernel
#: afresh, shooting elastic states, killing MPI ranks): started first, so that pytest-xdist's
#: two workers share out the short ones at the end and finish together (started where they
#: fall in the file order, one worker ran alone for about a minute at the end)
SLOW_FIRST = ("test_bounds.py", "test_forced_branch.py", "test_slider_shooting.py",
              "test_forced_shooting.py", "test_settle_faults.py", "test_tools.py")


def pytest_collection_modifyitems(config, items):
    def rank(item) -> int:
        name = os.path.basename(str(item.fspath))
        return SLOW_FIRST.index(name) if name in SLOW_FIRST else len(SLOW_FIRST)

    items.sort(key=rank)  # stable: the file order within each rank
