"""The segment mesh of a configuration: the built-in one or a user's file."""

from __future__ import annotations

from wheelrom.config import Config
from wheelrom.segment.builtin import build_builtin
from wheelrom.segment.mesh import SegmentMesh
from wheelrom.segment.reader import read_segment


def load_segment(cfg: Config) -> SegmentMesh:
    """``segment.source``: ``"builtin"`` (:func:`build_builtin`) or a mesh file
    (:func:`read_segment`)."""
    if cfg.segment.source == "builtin":
        return build_builtin(cfg)
    return read_segment(cfg)
