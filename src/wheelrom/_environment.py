"""Kept for scripts written against the earlier docs (``from wheelrom._environment import
bootstrap, petsc``); the module is :mod:`wheelrom.runtime.environment`."""

from wheelrom.runtime.environment import bootstrap, petsc, slepc

__all__ = ["bootstrap", "petsc", "slepc"]
