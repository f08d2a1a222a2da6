# SPDX-License-Identifier: MIT
"""The bridge's ROS parameters (docs/ros2.md), without ROS: ``mstc ros
--help`` lists them where ROS is not installed."""

from __future__ import annotations

from typing import Any

STEP_SOURCES = ("odom", "timer", "none")
"""Who steps the firmware: each odometry message, the bridge's timer, or the
firmware's own timer."""

PARAMETERS: dict[str, tuple[Any, str]] = {
    "can_interface": ("mstc-sil", "python-can interface: mstc-sil, socketcan, slcan, ..."),
    "can_channel": ("", "the interface's channel: can0, vcan0, /dev/ttyACM0; empty for mstc-sil"),
    "can_bitrate": (500000, "bit rate [bit/s] for interfaces that set it (slcan)"),
    "sil_lib": ("", "mstc-sil: the firmware library (default $MSTC_SIL_LIB, else the build's)"),
    "key_file": ("", "the firmware's key file (default $MSTC_KEY_FILE, else keys/device.key)"),
    "step_source": ("", "odom, timer or none (default: timer for mstc-sil, none otherwise)"),
    "rate_hz": (50.0, "control rate [Hz]: the timer's, and the one odometry steps keep"),
    "reference_source": ("plan", "plan (nav_msgs/Path at plan_speed) or reference (PoseStamped)"),
    "plan_speed": (0.5, "speed along the plan [m/s]"),
    "obstacle_timeout": (1.0, "obstacles older than this are no longer sent [s]"),
    "world_frame": ("odom", "the frame of odometry, reference, plan and obstacles (REP-105)"),
    "base_frame": ("base_link", "the robot's frame: /odom's child_frame_id (REP-105)"),
    "reference_frame": ("mstc_reference", "the reference's frame on /tf"),
    "left_wheel_joint": ("left_wheel_joint", "JointState name of the left wheel"),
    "right_wheel_joint": ("right_wheel_joint", "JointState name of the right wheel"),
    "publish_tf": (False, "publish world_frame -> base_frame and -> reference_frame on /tf"),
    "status_rate_hz": (2.0, "rate of mstc/status [Hz]"),
    "qos_depth": (10, "history depth of every topic"),
    "qos_reliability": ("reliable", "reliable or best_effort, for the inputs"),
    "command_timeout": (0.5, "how long an arm or parameter command waits for its answer [s]"),
}
"""The bridge's own ROS parameters: default and description."""

FIRMWARE_PREFIX = "firmware."
"""The firmware's parameters are the node's ``firmware.<name>`` (the DBC's
PARAM_SET_index names: ``firmware.D_s``, ``firmware.strategy``, ...)."""


def describe() -> str:
    """The parameters as ``mstc ros --help`` lists them."""
    width = max(len(n) for n in PARAMETERS)
    lines = []
    for name, (default, text) in PARAMETERS.items():
        lines.append(f"  {name:<{width}}  {text} (default: {default!r})")
    return "\n".join(lines)
