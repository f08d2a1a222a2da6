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
:class:`SilBus` restarts it and gives it its key (authenticated commands,
docs/safety.md): ``key=`` bytes, else :func:`mstc.can.secoc.load_key`.
"""

from __future__ import annotations

import ctypes
import errno
import os
from pathlib import Path
from typing import Any

import can

from mstc.can import secoc

LIB_ENV = "MSTC_SIL_LIB"
"""Environment variable naming the library when no ``lib`` is given."""


class _Frame(ctypes.Structure):
    """``mstc_sil_frame_t`` (hal/sil/mstc_sil.h)."""

    _fields_ = [
        ("id", ctypes.c_uint32),
        ("dlc", ctypes.c_uint8),
        ("data", ctypes.c_uint8 * 8),
    ]


class SilBus(can.BusABC):
    """The in-process firmware as a python-can bus.

    :param channel: a name for the bus in logs (default ``"sil0"``).
    :param lib: path of ``libmstc_sil.so``; default: ``$MSTC_SIL_LIB``.
    :param key: the firmware's key (16 bytes); default: :func:`mstc.can.secoc.load_key`.
    :param freshness: the firmware's freshness value at start (0, as after a reset).
    """

    def __init__(
        self,
        channel: Any = None,
        lib: str | os.PathLike[str] | None = None,
        key: bytes | None = None,
        freshness: int = 0,
        **kwargs: Any,
    ) -> None:
        path = lib if lib is not None else os.environ.get(LIB_ENV)
        if not path:
            raise can.CanInitializationError(
                f"mstc-sil: no firmware library: pass lib=... or set {LIB_ENV} (make lib builds it)"
            )
        if not Path(path).is_file():
            raise can.CanInitializationError(
                f"mstc-sil: cannot load firmware library {path}: no such file (make lib builds it)"
            )
        try:
            self._lib = ctypes.CDLL(str(Path(path).resolve()))
        except OSError as exc:
            raise can.CanInitializationError(
                f"mstc-sil: cannot load firmware library {path}: {exc}"
            ) from exc
        for name, args in (
            ("mstc_sil_fw_init", [ctypes.c_void_p]),
            ("mstc_sil_fw_send", [ctypes.POINTER(_Frame)]),
            ("mstc_sil_fw_recv", [ctypes.POINTER(_Frame)]),
            ("mstc_sil_fw_set_key", [ctypes.c_char_p, ctypes.c_size_t, ctypes.c_uint32]),
        ):
            fn = getattr(self._lib, name, None)
            if fn is None:
                raise can.CanInitializationError(f"mstc-sil: {path} has no {name}")
            fn.argtypes = args
            fn.restype = ctypes.c_int
        self._lib.mstc_sil_numeric.restype = ctypes.c_char_p
        self.numeric = self._lib.mstc_sil_numeric().decode()
        self.channel = channel if channel is not None else "sil0"
        self.channel_info = f"mstc-sil ({self.numeric}) {path}"
        self._now = 0.0
        rc = self._lib.mstc_sil_fw_init(None)
        if rc != 0:
            raise can.CanInitializationError(f"mstc-sil: firmware init failed ({rc})")
        try:
            key = secoc.load_key() if key is None else key
        except secoc.AuthKeyError as exc:
            raise can.CanInitializationError(f"mstc-sil: {exc}") from exc
        if self._lib.mstc_sil_fw_set_key(key, len(key), freshness) != 0:
            raise can.CanInitializationError(
                f"mstc-sil: the firmware refused the key ({len(key)} bytes, want {secoc.KEY_LEN})"
            )
        super().__init__(channel=self.channel, **kwargs)

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        """Hand @p msg to the firmware, which handles it before this returns."""
        if msg.is_extended_id or msg.is_remote_frame or msg.is_error_frame or msg.is_fd:
            raise can.CanOperationError(
                "mstc-sil: only classic data frames with 11-bit identifiers are supported"
            )
        if msg.dlc > 8 or len(msg.data) > 8 or msg.arbitration_id > 0x7FF:
            raise can.CanOperationError(f"mstc-sil: bad frame {msg}")
        frame = _Frame(msg.arbitration_id, len(msg.data))
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
        frame = _Frame()
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
