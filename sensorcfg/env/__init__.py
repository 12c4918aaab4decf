"""Adapters for experiment scripts: a dm_env Environment, a dm_control adapter, a Gymnasium wrapper."""

from .dm_control_adapter import dm_control_observables
from .environment import Environment, make_env

__all__ = ["Environment", "dm_control_observables", "make_env"]
