"""Launch the walker_gait node graph on a native ROS 2 Jazzy install (``ros2 launch walker_gait walker_gait.launch.py``).

Without a native install use ``walker-gait run`` (same nodes, same parameters file).
"""

from pathlib import Path

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

NODES = ("depth_to_cloud", "floor_segmentation", "leg_tracker", "gait_analyzer", "bag_replay")


def generate_launch_description() -> LaunchDescription:
    share = Path(get_package_share_directory("walker_gait"))
    params = LaunchConfiguration("params_file")
    remaps = [("depth/image_raw", LaunchConfiguration("depth_topic")),
              ("depth/camera_info", LaunchConfiguration("info_topic"))]
    return LaunchDescription([
        DeclareLaunchArgument("params_file", default_value=str(share / "config" / "walker_gait.yaml")),
        DeclareLaunchArgument("depth_topic", default_value="/depth/image_raw"),
        DeclareLaunchArgument("info_topic", default_value="/depth/camera_info"),
        *[Node(package="walker_gait", executable=name, name=name, parameters=[params], remappings=remaps,
               output="screen") for name in NODES],
    ])
