"""Exception hierarchy of pier_monitor.

Every error the package raises on purpose derives from :class:`PierMonitorError`,
so that callers (command line, ROS nodes) can catch the project's errors in one
place and still tell them apart.
"""

from __future__ import annotations

__all__ = [
    "PierMonitorError",
    "ConfigError",
    "InputDataError",
    "GroundMotionError",
    "UnsafeNameError",
    "SolverError",
    "BagError",
    "IdentificationError",
    "ReportError",
]


class PierMonitorError(Exception):
    """Base class of all errors raised by pier_monitor."""


class ConfigError(PierMonitorError):
    """A pier configuration is missing a field, has a wrong type or an impossible value.

    The message names the file (when known) and the dotted path of the field.
    """


class InputDataError(PierMonitorError):
    """Array arguments or measured data have the wrong shape, units or values."""


class GroundMotionError(InputDataError):
    """A ground-motion (accelerogram) file or array cannot be used."""


class UnsafeNameError(InputDataError):
    """An id that becomes a file or directory name is empty, too long or has characters
    outside ``[A-Za-z0-9_-]``, or an output path would leave its root directory."""


class SolverError(PierMonitorError):
    """The time integration failed (divergence, non-convergence, instability)."""


class BagError(PierMonitorError):
    """A rosbag2 directory or mcap file cannot be written or read."""


class IdentificationError(PierMonitorError):
    """The identification (PINN training) failed, e.g. a NaN loss."""


class ReportError(PierMonitorError):
    """Results, figures or a comparison cannot be written or read.

    The message names the file or directory, or says which results do not match.
    """
