# SPDX-License-Identifier: MIT
"""``mstc ros``: the board as a ROS 2 node (docs/ros2.md)."""

from __future__ import annotations

import argparse
import os

from mstc.cli.common import DEFAULT_LIB, EXIT_OK, EXIT_USAGE, error
from mstc.errors import RosError
from mstc.firmware import LIB_ENV
from mstc.ros import require
from mstc.ros.parameters import describe

NAME = "ros"
HELP = "bridge a CAN bus with the firmware on it to ROS 2 topics (a node Nav2 can drive)"

_EPILOG = f"""\
Everything after `mstc ros` goes to ROS 2: parameters with --ros-args -p NAME:=VALUE
or --params-file FILE, remappings with -r FROM:=TO. Topics, types and frames:
docs/ros2.md. The bridge's parameters:

{describe()}

and firmware.<name> for each of the firmware's parameters (firmware.D_s,
firmware.strategy, ...): given at start they are sent to the firmware, else
read from it; `ros2 param set /mstc_bridge firmware.D_s 0.4` sends one.
Arm with `ros2 service call /mstc_bridge/arm std_srvs/srv/SetBool "{{data: true}}"`.

Needs the extra mstc[ros] (pip install 'mstc[ros]'; `make venv` installs it).

exit status: 0 stopped (Ctrl-C); 2 ROS 2 not installed, a bad parameter, a bus
that cannot be opened, or a firmware that does not answer.

examples:
  .venv/bin/mstc ros                       # the firmware in process, on the bridge's timer
  .venv/bin/mstc ros --ros-args -p can_interface:=socketcan -p can_channel:=can0
  .venv/bin/mstc ros --ros-args --params-file sim/mstc/ros/launch/mstc_bridge.yaml
"""


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``mstc ros``."""
    parser = commands.add_parser(
        NAME,
        help=HELP,
        description="Run the ROS 2 bridge node mstc_bridge between a CAN bus and ROS 2.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "ros_args",
        nargs=argparse.REMAINDER,
        metavar="--ros-args ...",
        help="ROS 2 arguments: parameters, remappings, log level",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run the bridge until interrupted."""
    try:
        require("rclpy", "nav_msgs.msg", "visualization_msgs.msg", "diagnostic_msgs.msg")
        require("sensor_msgs.msg", "std_srvs.srv")
        from mstc.ros.bridge import run as run_bridge

        # The in-process firmware defaults to the source tree's build, as mstc sim's does.
        if LIB_ENV not in os.environ and DEFAULT_LIB is not None and DEFAULT_LIB.is_file():
            os.environ[LIB_ENV] = str(DEFAULT_LIB)
        run_bridge(args.ros_args)
    except RosError as exc:
        error(str(exc))
        return EXIT_USAGE
    return EXIT_OK
