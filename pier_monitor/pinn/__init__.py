"""The physics-informed neural network identifier (the package's only torch importer)."""

from __future__ import annotations

from .threads import set_threads
from .trainer import IdentificationRun, PinnSettings, Progress, Reproduced, identify, resolve_device

__all__ = ["IdentificationRun", "PinnSettings", "Progress", "Reproduced", "identify",
           "resolve_device", "set_threads"]
