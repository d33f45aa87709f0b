"""The physics-informed neural network (the package's only torch importer): the network,
its physics residuals and its training loop.  Choosing a method and assembling its result
is :mod:`pier_monitor.core.identify.methods`'s, which loads this package only when a PINN is
trained."""

from __future__ import annotations

from .threads import set_threads
from .trainer import resolve_device, train_pinn

__all__ = ["resolve_device", "set_threads", "train_pinn"]
