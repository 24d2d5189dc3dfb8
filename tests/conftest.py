"""Shared fixtures: small models built once per session."""

import os

import pytest

import wheelrom  # noqa: F401  (environment bootstrap before numpy/petsc)

os.environ.setdefault("MPLBACKEND", "Agg")
HERE = os.path.dirname(__file__)
SMALL = os.path.join(HERE, "data", "small.toml")


@pytest.fixture(scope="session")
def coarse_cfg():
    from wheelrom import config

    return config.load(overrides=['segment.preset="coarse"'])


@pytest.fixture(scope="session")
def coarse_segment(coarse_cfg):
    from wheelrom import assembly, mesh

    seg = mesh.build_builtin(coarse_cfg)
    mats = assembly.assemble(seg, 2.1e11, 0.3, 7850.0)
    return seg, mats


@pytest.fixture(scope="session")
def coarse_model(coarse_cfg):
    """66 blades x 10 modes on the coarse segment (the paper's ROM size)."""
    from wheelrom import cyclic

    return cyclic.build_model(coarse_cfg)


@pytest.fixture(scope="session")
def small_cfg():
    from wheelrom import config

    return config.load(SMALL)


@pytest.fixture(scope="session")
def small_model(small_cfg):
    from wheelrom import cyclic

    return cyclic.build_model(small_cfg)
