"""The rosbags typestore of the project: ROS 2 Kilted plus ``pier_monitor_msgs``.

The message definitions are read from their ``.msg`` text, so that bags are written and read
without a ROS installation and without building the interface package.  The text is taken
from the installed interface package when there is one (``<prefix>/share/pier_monitor_msgs/msg``
for ``sys.prefix`` and each ``AMENT_PREFIX_PATH`` entry: what a live ROS graph uses), else from
the repository's ``msg_defs/msg``.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pier_monitor.core.resources import find_share_path

from .errors import BagError

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = [
    "MSG_PACKAGE",
    "SAMPLE_BLOCK",
    "STRING",
    "KIND_CODES",
    "KIND_NAMES",
    "find_msg_dir",
    "get_typestore",
    "message_definition",
]

MSG_PACKAGE = "pier_monitor_msgs"
#: Type name of the block message of high-rate channels.
SAMPLE_BLOCK = f"{MSG_PACKAGE}/msg/SampleBlock"
#: Type name of the message that carries the pier configuration YAML.
STRING = "std_msgs/msg/String"

#: SampleBlock.kind code of each sensor kind of the pier configuration.
KIND_CODES = {"acceleration": 0, "displacement": 1, "velocity": 2}
KIND_NAMES = {code: name for name, code in KIND_CODES.items()}


def find_msg_dir() -> Path:
    """Directory holding the ``pier_monitor_msgs`` ``.msg`` files.

    Raises
    ------
    BagError
        If neither the installed interface package nor the repository's ``msg_defs/msg``
        can be found; the message lists where it looked.
    """
    try:
        path = find_share_path(MSG_PACKAGE, "msg", Path("msg_defs") / "msg")
    except FileNotFoundError as err:
        raise BagError(f"cannot find the {MSG_PACKAGE} message definitions: {err}. Install the "
                       "interface package (scripts/build_msgs.py) or run from a source "
                       "checkout") from err
    if not any(path.glob("*.msg")):
        raise BagError(f"no .msg files in {path} (the {MSG_PACKAGE} message definitions)")
    return path


@lru_cache(maxsize=1)
def get_typestore() -> Typestore:
    """A ROS 2 Kilted typestore with the ``pier_monitor_msgs`` types registered.

    The typestore is built once per process and shared: use it, do not register more types
    in it.

    Raises
    ------
    BagError
        If the message definitions cannot be found or parsed.
    """
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore as _get_typestore

    msg_dir = find_msg_dir()
    typestore = _get_typestore(Stores.ROS2_KILTED)
    types: dict[str, Any] = {}
    for path in sorted(msg_dir.glob("*.msg")):
        try:
            types.update(get_types_from_msg(path.read_text(encoding="utf-8"),
                                            f"{MSG_PACKAGE}/msg/{path.stem}"))
        except Exception as err:  # rosbags raises its own parser errors
            raise BagError(f"{path}: cannot parse message definition: {err}") from err
    typestore.register(types)
    return typestore


def message_definition(typename: str) -> tuple[str, str]:
    """The ROS 2 message definition text (with dependencies) and RIHS01 hash of a type."""
    typestore = get_typestore()
    msgdef, _ = typestore.generate_msgdef(typename, ros_version=2)
    return msgdef, typestore.hash_rihs01(typename)
