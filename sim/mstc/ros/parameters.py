# SPDX-License-Identifier: MIT
"""The bridge's ROS parameters (docs/ros2.md), without ROS: ``mstc ros
--help`` lists them where ROS is not installed."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from mstc.can.protocol import wire_limits
from mstc.limits import load_table
from mstc.plant.scenario import MAX_DT

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
    "rate_hz": (50.0, "control rate [Hz], at least 20: the timer's, the one odometry steps keep"),
    "reference_source": ("plan", "plan (nav_msgs/Path at plan_speed) or reference (PoseStamped)"),
    "plan_speed": (0.5, "speed along the plan [m/s], above 0, at most 15.9998"),
    "obstacle_timeout": (1.0, "obstacles older than this are no longer sent [s], above 0"),
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


@dataclass(frozen=True)
class Range:
    """The values a numeric parameter of the bridge takes: above @p lo (or at
    it, @p closed), at most @p hi, and finite."""

    lo: float
    hi: float = math.inf
    closed: bool = False
    why: str = ""
    """Where the bound comes from, when it is not plain positivity."""

    def problem(self, name: str, value: Any) -> str | None:
        """Why @p value is out of range, in one line; None when it is not."""
        if isinstance(value, bool) or not isinstance(value, int | float):
            return f"{name} {value!r}: a number"
        x = float(value)
        if not math.isfinite(x) or (x < self.lo if self.closed else x <= self.lo):
            if self.lo == 0 and not self.closed:
                return f"{name} {value!r}: a positive number"
            return f"{name} {value!r}: at least {self.lo:g}{self.why}"
        if x > self.hi:
            return f"{name} {value!r}: at most {self.hi:g}{self.why}"
        return None


RATE_MIN_HZ = 1.0 / MAX_DT
"""The lowest control rate [Hz]: the "mstc" safety filter's guarantee needs
a period of MAX_DT (50 ms) at most, as the scenario loader demands of sim.dt."""
STALE_PERIODS = int(load_table().halt["detection_periods"])
"""Periods the firmware waits for a fresh input frame before it halts
(APP_TIMEOUT_PERIODS, ctl_params.toml [halt]): a reference sample older
than this is no longer sent, nor is a late step run."""
STALE_S = float(load_table().halt["detection_s"])
"""... and the time the firmware waits (APP_TIMEOUT_US) [s]."""
FUTURE_BOUND_S = 1.0
"""A stamp (odometry with step_source odom, a reference pose) more than this
ahead of the node's clock is refused and counted [s]."""

RANGES: dict[str, Range] = {
    "rate_hz": Range(
        0.0,
        why=f" Hz: a period of {MAX_DT * 1e3:g} ms at most, the safety filter's "
        "(alpha dt <= 1 with alpha = 20/s; docs/strategy.md)",
    ),
    "status_rate_hz": Range(0.0),
    "command_timeout": Range(0.0),
    "plan_speed": Range(
        0.0,
        wire_limits().v.hi,
        why=" m/s: REF_MOTION's v carries no more",
    ),
    "obstacle_timeout": Range(0.0),
    "qos_depth": Range(1.0, closed=True),
    "can_bitrate": Range(0.0),
}
"""The range of each numeric parameter of the bridge; rate_hz also needs
RATE_MIN_HZ (:func:`problem`)."""
RUN_TIME = ("plan_speed", "obstacle_timeout")
"""The bridge's parameters that may change while it runs; the others are
read at start."""


def problem(name: str, value: Any) -> str | None:
    """Why @p value is not a value of the bridge's parameter @p name, in one
    line; None when it is (or @p name has no range)."""
    r = RANGES.get(name)
    if r is None:
        return None
    why = r.problem(name, value)
    if why is None and name == "rate_hz":
        why = Range(RATE_MIN_HZ, closed=True, why=r.why).problem(name, value)
    return why


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
