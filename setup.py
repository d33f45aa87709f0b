from glob import glob

from setuptools import find_packages, setup

package_name = "pier_monitor"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*"]),
    # the El Centro 1940 record (pier_monitor/data), read with importlib.resources
    package_data={package_name: ["data/*.txt"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", sorted(glob("config/*.yaml"))),
        # launch_files/ in the source tree (a launch/ folder would shadow the launch package
        # when Python runs from the repository root); installed where ros2 launch looks
        ("share/" + package_name + "/launch", sorted(glob("launch_files/*.launch.py"))),
    ],
    # Runtime dependencies (ROS 2 wheels, torch, numpy, ...) are pinned in requirements.txt
    # and declared for rosdep in package.xml; setuptools only needs itself here.
    install_requires=["setuptools"],
    # the fiber-section column of the ``fiber`` benchmark (OpenSees; 3.7.1.2 is the last for
    # Python 3.11; needs the system BLAS/LAPACK: Debian libblas3 liblapack3)
    extras_require={"fiber": ["openseespy==3.7.1.2"]},
    zip_safe=True,
    maintainer="pier_monitor maintainers",
    maintainer_email="pier-monitor@example.com",
    description="Physics-informed damage identification of reinforced-concrete bridge piers",
    license="Apache-2.0",
    python_requires=">=3.10",
    # The node executables, as ament_python packages declare them: colcon installs them into
    # lib/pier_monitor (setup.cfg), where `ros2 run pier_monitor ingest` looks.
    entry_points={
        "console_scripts": [
            "pier-monitor = pier_monitor.cli:main",
            "ingest = pier_monitor.nodes.ingest_node:main",
            "identifier = pier_monitor.nodes.identifier_node:main",
        ],
    },
)
