# SPDX-License-Identifier: MIT
"""ROS 2 is optional (the extra mstc[ros]): with its packages hidden, every
module of mstc imports but the two that speak ROS (the bridge node and the
rosbag2 writer), and the two commands that need them (``mstc ros``,
``mstc export --rosbag2``) say in one line what to install. Run in a
subprocess whose import system refuses the ROS packages, as an installation
without them would. ``mstc ros`` hands ROS 2 what follows ``--ros-args``,
options included, through argparse alone."""

from __future__ import annotations

import argparse
import subprocess
import sys
import textwrap

import pytest

from conftest import ROOT
from mstc.cli import build_parser

NEED_ROS = ("mstc.ros.bridge", "mstc.ros.bag")
"""The modules that import ROS packages (rclpy, the messages, rosbags)."""

HIDE = textwrap.dedent(
    """
    import sys
    ROS = ("rclpy", "rosbags", "builtin_interfaces", "diagnostic_msgs", "geometry_msgs",
           "nav_msgs", "rcl_interfaces", "sensor_msgs", "std_msgs", "std_srvs", "tf2_msgs",
           "visualization_msgs")

    class Hide:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in ROS:
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
            return None

    sys.meta_path.insert(0, Hide())
    """
)


def run(code: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", HIDE + textwrap.dedent(code)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_the_package_imports_without_ros() -> None:
    """Everything but the bridge node and the writer: the rest of the package,
    the command ``mstc ros`` and the bridge's CAN side, reference and
    parameters."""
    done = run(
        f"""
        import importlib, pkgutil, mstc
        names = [m.name for m in pkgutil.walk_packages(mstc.__path__, "mstc.")]
        assert set({NEED_ROS!r}) <= set(names), names
        others = [n for n in names if n not in {NEED_ROS!r} and n != "mstc.__main__"]
        assert {{"mstc.cli.ros", "mstc.ros.board", "mstc.ros.reference"}} <= set(others)
        assert len(others) > 60, others
        for name in others:
            importlib.import_module(name)
        assert not [m for m in sys.modules if m.split(".")[0] in ROS]
        print("imported", len(others))
        """
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("imported")


def test_mstc_ros_says_what_to_install() -> None:
    done = run(
        """
        from mstc.cli import main
        sys.exit(main(["ros"]))
        """
    )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith("error: rclpy is not installed: pip install 'mstc[ros]'")


def test_export_rosbag2_says_what_to_install(tmp_path: object) -> None:
    done = run(
        f"""
        from mstc.cli import main
        sys.exit(main(["export", "{ROOT}/tests/data/paper-line.log", "--rosbag2", "{tmp_path}/b"]))
        """
    )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith("error: rosbags is not installed: pip install 'mstc[ros]'")


def ros_args(*argv: str) -> argparse.Namespace:
    return build_parser().parse_args(["ros", *argv])


def test_what_follows_ros_args_is_ros_s() -> None:
    """ROS's own options after --ros-args, in their order, even those
    argparse would take for its own (-h, --version)."""
    args = ros_args(
        "--ros-args", "-p", "can_channel:=can0", "--params-file", "f.yaml", "-r", "odom:=/o", "-h"
    )
    assert args.ros_args == [
        "-p", "can_channel:=can0", "--params-file", "f.yaml", "-r", "odom:=/o", "-h"
    ]  # fmt: skip
    assert ros_args().ros_args == []


def test_mstc_ros_help_lists_the_bridge_s_parameters(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as done:
        ros_args("--help")
    assert done.value.code == 0
    out = capsys.readouterr().out
    assert "--ros-args ..." in out
    assert "can_interface" in out and "step_source" in out and "firmware.<name>" in out


def test_ros_arguments_without_ros_args_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    """ROS itself wants --ros-args before -p: a bare -p is a usage error."""
    with pytest.raises(SystemExit) as done:
        ros_args("-p", "can_channel:=can0")
    assert done.value.code == 2
    assert "unrecognized arguments: -p can_channel:=can0" in capsys.readouterr().err
