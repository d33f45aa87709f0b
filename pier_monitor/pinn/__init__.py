"""The physics-informed neural network identifier (the package's only torch importer)."""

from __future__ import annotations

from .trainer import IdentificationRun, PinnSettings, Progress, Reproduced, identify, resolve_device

__all__ = ["IdentificationRun", "PinnSettings", "Progress", "Reproduced", "identify",
           "resolve_device"]
