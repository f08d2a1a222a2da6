# SPDX-License-Identifier: MIT
"""ROS 2 is optional (the extra mstc[ros]): with its packages hidden, every
module of mstc outside mstc.ros imports, and the two commands that need
them (``mstc ros``, ``mstc export --rosbag2``) say in one line what to
install. Run in a subprocess whose import system refuses the ROS packages,
as an installation without them would."""

from __future__ import annotations

import subprocess
import sys
import textwrap

from conftest import ROOT

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
    done = run(
        """
        import importlib, pkgutil, mstc
        names = [m.name for m in pkgutil.walk_packages(mstc.__path__, "mstc.")]
        others = [n for n in names if not n.startswith("mstc.ros.") and n != "mstc.__main__"]
        assert "mstc.cli.ros" in others and len(others) > 40, others
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
    assert "needs rosbags" in lines[0] and "pip install 'mstc[ros]'" in lines[0]
