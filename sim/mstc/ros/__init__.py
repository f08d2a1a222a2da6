# SPDX-License-Identifier: MIT
"""ROS 2 at the edge of mstc (docs/ros2.md): the bridge node ``mstc ros``
(:mod:`~mstc.ros.bridge`), its CAN side (:mod:`~mstc.ros.board`), the
reference it makes of a path (:mod:`~mstc.ros.reference`), its parameters
(:mod:`~mstc.ros.parameters`), and runs written as rosbag2
(:mod:`~mstc.ros.bag`).

Optional: the ROS 2 packages come with the extra ``mstc[ros]``. Only the
command line (:mod:`mstc.cli`) imports this package (its layer is right
under the command's, docs/architecture.md), and importing it, its board,
reference and parameters imports no ROS package; :func:`require` says in one
line what to install when they are missing.
"""

from __future__ import annotations

import importlib

from mstc.errors import DependencyError

INSTALL_HINT = (
    "pip install 'mstc[ros]' (the ROS 2 Kilted wheels: ros-rclpy, ros-rmw-fastrtps-cpp and "
    "the message packages, and rosbags), or `make venv` in the source tree; "
    "or source a ROS 2 installation"
)


def require(*modules: str) -> None:
    """Import @p modules, or raise one line naming what is missing and how
    to install it.

    :raises DependencyError: a module cannot be imported.
    """
    for name in modules:
        try:
            importlib.import_module(name)
        except ImportError as exc:
            raise DependencyError(f"{exc.name or name} is not installed: {INSTALL_HINT}") from exc
