"""ament_python package walker_gait (also pip-installable into a plain venv, see README)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "walker_gait"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*"]),
    package_data={PACKAGE: ["data/*"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
        ("share/" + PACKAGE + "/config", glob("config/*.yaml")),
        ("share/" + PACKAGE + "/launch", glob("launch/*.py")),
    ],
    install_requires=["setuptools"],
    zip_safe=False,
    maintainer="walker_gait developers",
    maintainer_email="walker-gait-dev@example.org",
    description="Depth-camera gait analysis for an instrumented wheeled walker (ROS 2 Jazzy).",
    license="Apache-2.0",
    python_requires=">=3.10",
    entry_points={
        "console_scripts": [
            "walker-gait = walker_gait.cli:main",
            "depth_to_cloud = walker_gait.ros.nodes:depth_to_cloud_main",
            "floor_segmentation = walker_gait.ros.nodes:floor_segmentation_main",
            "leg_tracker = walker_gait.ros.nodes:leg_tracker_main",
            "gait_analyzer = walker_gait.ros.nodes:gait_analyzer_main",
            "bag_replay = walker_gait.ros.nodes:bag_replay_main",
        ],
    },
)
