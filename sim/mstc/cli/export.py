# SPDX-License-Identifier: MIT
"""``mstc export``: a run or a bus log as an MCAP file, for Foxglove, or as a
rosbag2, for the ROS 2 tools."""

from __future__ import annotations

import argparse
from pathlib import Path

from mstc.cli import COMMANDS
from mstc.cli.common import add_log_arguments, load_decoded
from mstc.errors import EXIT_OK
from mstc.logs.export import export_mcap, format_summary
from mstc.ros import require

NAME = "export"
HELP = COMMANDS[NAME]

_EPILOG = """\
RUN_DIR is a folder mstc sim or mstc hil wrote (its bus.log is read); LOG is
any bus log mstc replay reads. The file holds every CAN frame decoded with the
DBC on /can/<MESSAGE> (JSON), the robot's and the reference's poses and paths,
the obstacles and the switching events as Foxglove schemas (protobuf), each
stamped with the log's time. Open it in Foxglove: its 3D panel shows the
paths and obstacles in the frame "odom" (REP 105, as the rosbag2 export);
a Plot panel takes any signal, e.g.
/can/STATUS.e. See docs/replay.md.

With --rosbag2 the run becomes a rosbag2 folder (MCAP storage) of standard ROS 2
messages in the frames odom and base_link: /odom, /tf, /reference,
/reference/path, /obstacles, /cmd_wheels, /joint_states (the measured wheel
speeds, when the run has them), /mstc/status, /mstc/events and every
raw frame on /can/frames (can_msgs/msg/Frame), for ros2 bag play, rviz2, rqt
(docs/ros2.md). It needs the extra mstc[ros].

Either replaces what an earlier export wrote at the same path (the MCAP file,
the rosbag2 folder); a path that holds anything else is left alone.

exit status: 0 written; 1 the file cannot be written (a path that holds
something other than an earlier export); 2 bad arguments, a log that cannot
be used (with --strict, any problem in it; a run.json beside it that does not
say when the run started), or --rosbag2 without rosbags installed.

A simulation's bus.log counts from 0: the export places it at the run's
start, which mstc sim writes beside it (run.json); a log elsewhere keeps its
own stamps.

examples:
  .venv/bin/mstc export tests/data/paper-line.log --mcap build/paper-line.mcap
  .venv/bin/mstc export build/sim/paper-line --mcap build/sim/paper-line/run.mcap
  .venv/bin/mstc export build/sim/paper-line --rosbag2 build/sim/paper-line/rosbag2
"""


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``mstc export``."""
    parser = commands.add_parser(
        NAME,
        help=HELP,
        description="Export a run folder or a bus log to MCAP or rosbag2, decoded with the DBC.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_log_arguments(parser, "RUN_DIR|LOG", "a run's folder (its bus.log is read), or a bus log")
    formats = parser.add_mutually_exclusive_group(required=True)
    formats.add_argument("--mcap", metavar="OUT", type=Path, help="the MCAP file to write")
    formats.add_argument(
        "--rosbag2",
        metavar="OUT",
        type=Path,
        help="the rosbag2 folder to write (MCAP storage, standard ROS 2 messages; needs "
        "the extra mstc[ros]; docs/ros2.md)",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Decode the log and write the MCAP file or the rosbag2."""
    source = args.log
    if args.rosbag2 is not None:
        require("rosbags")  # before the log is read: a missing extra is said at once
        from mstc.ros.bag import export_rosbag2

        db, decoded = load_decoded(args)
        summary = export_rosbag2(decoded, db, args.rosbag2)
    else:
        db, decoded = load_decoded(args)
        summary = export_mcap(decoded, db, args.mcap)
    print(format_summary(summary, source))
    return EXIT_OK
