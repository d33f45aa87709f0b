"""Declaring node parameters with descriptions, units and ranges (shared by the nodes)."""

from __future__ import annotations

from typing import Any

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType)
from rclpy.node import Node
from rclpy.parameter import Parameter

__all__ = ["declare"]


def declare(node: Node, name: str, default: Any, description: str, *, unit: str = "",
            lo: float | None = None, hi: float | None = None, read_only: bool = False,
            choices: tuple[str, ...] = (), string_array: bool = False) -> Any:
    """Declare one parameter; returns its value (possibly overridden by a params file).

    ``lo``/``hi`` become the descriptor's range (rclpy then rejects values outside it with a
    reason); ``choices`` are listed in the constraints and checked by the node's on-set
    callback.
    """
    text = description + (f" [{unit}]" if unit else "")
    descriptor = ParameterDescriptor(name=name, description=text, read_only=read_only)
    if choices:
        descriptor.additional_constraints = "one of: " + ", ".join(choices)
    if isinstance(default, bool):
        pass
    elif isinstance(default, int) and lo is not None:
        descriptor.integer_range = [IntegerRange(from_value=int(lo), to_value=int(hi), step=0)]
    elif isinstance(default, float) and lo is not None:
        descriptor.floating_point_range = [FloatingPointRange(from_value=float(lo),
                                                              to_value=float(hi), step=0.0)]
    if string_array:
        # rclpy cannot infer a type from []: declare it statically typed, unset = empty
        descriptor.type = ParameterType.PARAMETER_STRING_ARRAY
        value = node.declare_parameter(name, Parameter.Type.STRING_ARRAY, descriptor).value
        return [v for v in (value or default) if v]
    return node.declare_parameter(name, default, descriptor).value
