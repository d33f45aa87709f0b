"""Errors of the bag subpackage: the project's :class:`~pier_monitor.core.errors.BagError`.

Every failure to write or read a bag is a :class:`BagError` whose message names the file
(and the topic or time when one is involved).  Configuration problems found in a bag's
embedded configuration surface as :class:`~pier_monitor.core.errors.ConfigError` naming the
bag and topic.
"""

from __future__ import annotations

from pier_monitor.core.errors import BagError

__all__ = ["BagError"]
