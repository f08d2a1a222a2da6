# SPDX-License-Identifier: MIT
"""What ``mstc/status`` and ``mstc/events`` say (diagnostic_msgs), without
ROS: the bridge (:mod:`mstc.ros.bridge`, live) and the rosbag2 export
(:mod:`mstc.ros.bag`, from a log) build their DiagnosticStatus messages from
these, so a bag reads like the bridge's topics."""

from __future__ import annotations

from mstc.model import Event

OK, WARN, ERROR, STALE = 0, 1, 2, 3
"""diagnostic_msgs/msg/DiagnosticStatus levels."""
CONTROLLER = "mstc: controller"
"""Name of the status of ``mstc/status``: the firmware's latest step."""
EVENT = "mstc: event"
"""Name of a switching event's status on ``mstc/events``."""
BRIDGE = "mstc: bridge"
"""Name of the bridge's own events on ``mstc/events``: running, halted."""


def event_status(event: Event) -> tuple[str, list[tuple[str, str]]]:
    """The message and the key-values of @p event's status (level OK)."""
    side = f" {event.side}" if event.side else ""
    values = [
        ("kind", str(event.kind)),
        ("obstacle", str(event.obstacle)),
        ("side", str(event.side or "")),
        ("t", f"{event.t:.6f}"),
    ]
    return f"{event.kind} O{event.obstacle}{side}", values


def controller_level(mode: str, halt: str) -> tuple[int, str]:
    """Level and message of the controller's status in @p mode with the
    STATUS_halt entry @p halt: OK and the mode while it runs (``none``), WARN
    not armed, ERROR halted for another reason."""
    if halt == "none":
        return OK, mode
    if halt == "not_armed":
        return WARN, "not armed"
    return ERROR, f"halted: {halt}"
