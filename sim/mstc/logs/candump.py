# SPDX-License-Identifier: MIT
"""Bus logs in ``candump -L`` format, byte for byte.

One frame a line: ``(1700000000.123456) vcan0 123#0011223344556677``: the time
stamp in seconds with six decimals, the interface, the identifier in three
upper-case hex digits and the payload in upper-case hex. canplayer,
python-can's ``LogReader`` and ``cantools decode`` read it as it is.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import can


def candump_line(msg: can.Message, channel: str) -> str:
    """One ``candump -L`` line (without the newline) for a classic data frame."""
    if msg.is_extended_id or msg.is_remote_frame or msg.is_error_frame or msg.is_fd:
        raise ValueError(f"not a classic data frame with an 11-bit identifier: {msg}")
    return (
        f"({msg.timestamp:.6f}) {channel} {msg.arbitration_id:03X}#{bytes(msg.data).hex().upper()}"
    )


def write_candump(path: Path, frames: Iterable[can.Message], channel: str) -> None:
    """Write @p frames to @p path, one line each, in order."""
    path.write_text("".join(candump_line(m, channel) + "\n" for m in frames))
