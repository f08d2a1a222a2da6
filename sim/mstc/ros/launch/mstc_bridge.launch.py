# SPDX-License-Identifier: MIT
"""Launch description of the mstc bridge (docs/ros2.md), for a ROS 2
installation with the launch packages:

    ros2 launch sim/mstc/ros/launch/mstc_bridge.launch.py \
        params:=sim/mstc/ros/launch/mstc_bridge.yaml

mstc is a Python package, not an ament package, so the bridge is started as
the process ``mstc ros`` (ExecuteProcess), with the parameters file and the
remappings given here; the topics are remapped the way Nav2 names them.
"""

from pathlib import Path

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
from launch.substitutions import LaunchConfiguration

HERE = Path(__file__).resolve().parent


def generate_launch_description() -> LaunchDescription:
    params = LaunchConfiguration("params")
    mstc = LaunchConfiguration("mstc")
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "params",
                default_value=str(HERE / "mstc_bridge.yaml"),
                description="the bridge's parameters file",
            ),
            DeclareLaunchArgument(
                "mstc", default_value="mstc", description="the mstc command (e.g. .venv/bin/mstc)"
            ),
            DeclareLaunchArgument("odom", default_value="/odom"),
            DeclareLaunchArgument("plan", default_value="/plan"),
            DeclareLaunchArgument("obstacles", default_value="/obstacles"),
            ExecuteProcess(
                cmd=[
                    mstc,
                    "ros",
                    "--ros-args",
                    "--params-file",
                    params,
                    "-r",
                    ["odom:=", LaunchConfiguration("odom")],
                    "-r",
                    ["plan:=", LaunchConfiguration("plan")],
                    "-r",
                    ["obstacles:=", LaunchConfiguration("obstacles")],
                ],
                name="mstc_bridge",
                output="screen",
            ),
        ]
    )
