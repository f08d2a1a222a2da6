# SPDX-License-Identifier: MIT
"""python-can interface ``mstc-sil``: the firmware in process, behind CAN frames.

Registered through the ``can.interface`` entry point, so the plant reaches the
in-process firmware exactly as it reaches a board::

    bus = can.Bus(interface="mstc-sil", lib="build/host/float/libmstc_sil.so")
    bus = can.Bus(interface="socketcan", channel="vcan0")   # mstc-fw or a board

Frames sent on this bus go through the SIL HAL's queues to the same
application code that runs in ``mstc-fw`` and on boards (``hal/sil``); the
firmware handles each frame before :meth:`SilBus.send` returns, and its answers
wait for :meth:`SilBus.recv`. The firmware has no clock of its own here: the
frames it sends are stamped with the timestamp of the last frame it was sent,
so a lock-step run is deterministic.

One firmware instance exists per loaded library, as on a board: a new
:class:`SilBus` restarts it.
"""

from __future__ import annotations

import ctypes
import errno
import os
from typing import Any

import can

from mstc.can import secoc
from mstc.can.library import FRAME_DATA, FrameStruct, Library
from mstc.errors import AuthKeyError, FirmwareError


class SilBus(can.BusABC):
    """The in-process firmware as a python-can bus.

    :param channel: a name for the bus in logs (default ``"sil0"``).
    :param lib: path of ``libmstc_sil.so``; default: ``$MSTC_SIL_LIB``.
    :param key: the firmware's key (16 bytes); default: :func:`mstc.can.secoc.load_key`.
    :param session: the session of the firmware's authenticated commands; by
        default one drawn from the OS at start, as a board draws one at every
        start (docs/safety.md, "Sessions"). Only the replay of a log sets it:
        to the session the log was recorded in.
    :param node: the firmware's node id, 0..6 (its identifiers are the DBC's
        plus 0x100 times it); default: the build's (NODE= of make, 0).
    :raises can.CanInitializationError: the library cannot be loaded (its
        bindings, :class:`mstc.can.library.Library`, say why), the firmware
        started, or the key read.
    """

    def __init__(
        self,
        channel: Any = None,
        lib: str | os.PathLike[str] | None = None,
        key: bytes | None = None,
        session: int | None = None,
        node: int | None = None,
        **kwargs: Any,
    ) -> None:
        try:
            library = Library.open(lib)
        except FirmwareError as exc:
            raise can.CanInitializationError(f"mstc-sil: {exc}") from exc
        self._lib = library.dll
        self.numeric = library.numeric
        self.channel = channel if channel is not None else "sil0"
        self.channel_info = f"mstc-sil ({self.numeric}) {library.path}"
        self._now = 0.0
        self._node = node
        self._wheels: int | None = None
        try:
            self._key = secoc.load_key() if key is None else key
        except AuthKeyError as exc:
            raise can.CanInitializationError(f"mstc-sil: {exc}") from exc
        self.restart()
        if session is not None:
            self._lib.mstc_sil_fw_set_session(session)
        super().__init__(channel=self.channel, **kwargs)

    def restart(self) -> None:
        """Restart the firmware instance, as a board's reset does: empty queues,
        a fresh state, the same key, a session of its own.

        :raises can.CanInitializationError: the firmware did not start.
        """
        rc = self._lib.mstc_sil_fw_init(None)
        if rc != 0:
            raise can.CanInitializationError(f"mstc-sil: firmware init failed ({rc})")
        if self._node is not None and self._lib.mstc_sil_fw_set_node(self._node) != 0:
            raise can.CanInitializationError(f"mstc-sil: node id {self._node}: 0 to 6")
        if self._lib.mstc_sil_fw_set_key(self._key, len(self._key)) != 0:
            raise can.CanInitializationError(
                f"mstc-sil: the firmware refused the key ({len(self._key)} bytes, want "
                f"{secoc.KEY_LEN}), or the OS gave no random value for its session"
            )
        if self._wheels is not None:
            self._lib.mstc_sil_fw_wheels(self._wheels)

    def attach_wheels(self, address: int | None) -> None:
        """Make the firmware an integrated board whose own wheel loop runs the
        wheels at @p address (a wheel loop on two motors of this library:
        :attr:`mstc.firmware.wheels.WheelLoop.address`), which the caller
        advances: each control step takes their estimate and its age, and
        WHEEL_SPEED frames are not its input (docs/wheel.md, "Two
        topologies"). None: external drives again. Kept across
        :meth:`restart`."""
        self._wheels = address
        self._lib.mstc_sil_fw_wheels(address)

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        """Hand @p msg to the firmware, which handles it before this returns."""
        if msg.is_extended_id or msg.is_remote_frame or msg.is_error_frame or msg.is_fd:
            raise can.CanOperationError(
                "mstc-sil: only classic data frames with 11-bit identifiers are supported"
            )
        if msg.dlc > FRAME_DATA or len(msg.data) > FRAME_DATA or msg.arbitration_id > 0x7FF:
            raise can.CanOperationError(f"mstc-sil: bad frame {msg}")
        frame = FrameStruct(msg.arbitration_id, len(msg.data))
        frame.data[: len(msg.data)] = list(msg.data)
        if msg.timestamp:
            self._now = msg.timestamp
        rc = self._lib.mstc_sil_fw_send(ctypes.byref(frame))
        if rc == -errno.EAGAIN:
            raise can.CanOperationError("mstc-sil: the firmware's receive queue is full")
        if rc != 0:
            raise can.CanOperationError(f"mstc-sil: frame rejected ({rc})")

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        # Nothing arrives while we wait: the firmware only answers frames.
        frame = FrameStruct()
        if self._lib.mstc_sil_fw_recv(ctypes.byref(frame)) != 0:
            return None, False
        msg = can.Message(
            timestamp=self._now,
            arbitration_id=frame.id,
            is_extended_id=False,
            dlc=frame.dlc,
            data=bytes(frame.data[: frame.dlc]),
            channel=self.channel,
            is_rx=True,
        )
        return msg, False
