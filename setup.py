"""ament_python packaging of tethernet_ros.

Works both with colcon on a full ROS 2 Jazzy install (``colcon build --base-paths msg_defs .``,
then ``ros2 run tethernet_ros sim_node``) and with ``pip install -e .`` in the project's
.venv (scripts/setup.sh), where the console scripts land in ``.venv/bin``.
"""
from glob import glob

from setuptools import find_packages, setup

PACKAGE = "tethernet_ros"

setup(
    name=PACKAGE,
    version="0.1.0",
    description="Tether-net space-debris capture simulator with ROS 2 nodes",
    license="MIT",
    maintainer="tethernet maintainers",
    maintainer_email="maintainer@tethernet.dev",
    python_requires=">=3.10",
    packages=find_packages(include=[PACKAGE, PACKAGE + ".*", "optimizer", "optimizer.*"]),
    package_data={PACKAGE: ["data/targets/*.stl"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
        ("share/" + PACKAGE + "/launch", sorted(glob("launch/*.py"))),
        ("share/" + PACKAGE + "/config", sorted(glob("config/*.yaml"))),
    ],
    # Runtime dependencies are pinned in requirements*.txt (pip) and package.xml (rosdep);
    # not repeated here so that colcon builds do not try to resolve them with setuptools.
    install_requires=["setuptools"],
    zip_safe=False,
    entry_points={
        "console_scripts": [
            "tethernet = tethernet_ros.cli:main",
            "sim_node = tethernet_ros.ros.nodes.sim_node:main",
            "monitor_node = tethernet_ros.ros.nodes.monitor_node:main",
            "actuator_node = tethernet_ros.ros.nodes.actuator_node:main",
            "sensor_node = tethernet_ros.ros.nodes.sensor_node:main",
            "capture_node = tethernet_ros.ros.nodes.capture_node:main",
            "example_controller = tethernet_ros.ros.examples.lead_controller:main",
        ],
    },
)
