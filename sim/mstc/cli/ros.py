# SPDX-License-Identifier: MIT
"""``mstc ros``: the board as a ROS 2 node (docs/ros2.md)."""

from __future__ import annotations

import argparse
import os

from mstc.can.library import LIB_ENV
from mstc.cli import COMMANDS
from mstc.cli.common import find_library
from mstc.errors import EXIT_OK
from mstc.ros import require
from mstc.ros.parameters import describe

NAME = "ros"
HELP = COMMANDS[NAME]

_EPILOG = f"""\
Everything after --ros-args goes to ROS 2, as for any ROS 2 node: parameters
with -p NAME:=VALUE or --params-file FILE, remappings with -r FROM:=TO, the log
level with --log-level LEVEL. Topics, types and frames: docs/ros2.md. The
bridge's parameters:

{describe()}

and firmware.<name> for each of the firmware's parameters (firmware.D_s,
firmware.strategy, ...): given at start they are sent to the firmware, else
read from it; `ros2 param set /mstc_bridge firmware.D_s 0.4` sends one.
Arm with `ros2 service call /mstc_bridge/arm std_srvs/srv/SetBool "{{data: true}}"`.

Needs the extra mstc[ros] (pip install 'mstc[ros]'; `make venv` installs it).

exit status: 0 stopped (Ctrl-C, SIGTERM); 1 the firmware does not answer on the bus;
2 ROS 2 not installed, a bad parameter or no key; 3 a bus that cannot be opened.

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
    # ROS's own convention: what follows --ros-args is ROS's, options included.
    parser.add_argument(
        "--ros-args",
        dest="ros_args",
        nargs=argparse.REMAINDER,
        default=[],
        metavar="ARG",
        help="ROS 2 arguments, to the end of the line: parameters, remappings, log level",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run the bridge until interrupted.

    :raises DependencyError: ROS 2 is not installed.
    :raises MstcError: the bridge cannot start (:class:`mstc.ros.bridge.Bridge`).
    """
    require("rclpy", "nav_msgs.msg", "visualization_msgs.msg", "diagnostic_msgs.msg")
    require("sensor_msgs.msg", "std_srvs.srv")
    from mstc.ros.bridge import run as run_bridge

    # The in-process firmware defaults to the source tree's build, as mstc sim's does.
    lib = find_library(None)
    if lib is not None:
        os.environ.setdefault(LIB_ENV, str(lib))
    run_bridge(["--ros-args", *args.ros_args] if args.ros_args else [])
    return EXIT_OK
