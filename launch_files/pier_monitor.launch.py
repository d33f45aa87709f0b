"""A pier's graph, the ingest and identifier nodes, for ``ros2 launch``.

``ros2 launch pier_monitor pier_monitor.launch.py namespace:=/edefense_pier
params_file:=/path/to/nodes.yaml``

Both nodes run in the pier's namespace (relative topics: one namespace per pier) with one
parameters file (default: the package's ``config/nodes.yaml``).  On a machine without
``ros2 launch``, ``launch_free_scripts/start_graph.py`` starts the same two nodes.
"""

from __future__ import annotations

from pathlib import Path

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PACKAGE = "pier_monitor"
#: (executable, node name), as declared in setup.py's console_scripts.
NODES = (("ingest", "ingest"), ("identifier", "identifier"))


def generate_launch_description() -> LaunchDescription:
    """The launch description: two arguments and the two nodes."""
    default_params = Path(get_package_share_directory(PACKAGE)) / "config" / "nodes.yaml"
    namespace = LaunchConfiguration("namespace")
    params_file = LaunchConfiguration("params_file")
    return LaunchDescription([
        DeclareLaunchArgument("namespace", default_value="/edefense_pier",
                              description="The pier's namespace, e.g. /edefense_pier"),
        DeclareLaunchArgument("params_file", default_value=str(default_params),
                              description="ros__parameters file of both nodes"),
        *(Node(package=PACKAGE, executable=executable, name=name, namespace=namespace,
               parameters=[params_file], output="screen", emulate_tty=True)
          for executable, name in NODES),
    ])
