"""MuJoCo's own sensor types as suite kinds, added to a model through MjSpec (see `table`)."""

from .bind import bind_native, carry_hint
from .compile import add_native, compile_model, native_names, reads_on_demand
from .additions import native_row, sensor_name
from .table import NATIVE

__all__ = ["NATIVE", "add_native", "bind_native", "carry_hint", "compile_model", "native_names", "native_row",
           "reads_on_demand", "sensor_name"]
