# SPDX-License-Identifier: MIT
"""The vcan VM's bridge, from the host's side (``tools/vm/with-vcan --bridge``,
docs/hil.md "The bridge").

Where the host kernel has no CAN, with-vcan boots a small VM whose kernel has
vcan, runs the firmware there (``mstc-fw`` on ``vcan0``) and the command on
the host, natively: only the kernel's vcan and the firmware run on the emulated
CPU. Two virtio-serial ports join them:

- the **bus**: ``tools/vm/can-bridge.c`` in the guest speaks slcan on a port
  that QEMU connects to a TCP socket on the host, and passes each frame to and
  from ``vcan0`` in order. :class:`BridgeBus` is the host's end, a python-can
  bus; python-can's own ``slcan`` interface (``socket://127.0.0.1:PORT``)
  reaches the same bus.
- the **control** line: ``tools/vm/guest-agent`` in the guest starts and stops
  programs there (:func:`run`, which :func:`mstc.firmware.process.start_firmware`
  puts in front of ``mstc-fw``) and reports the bridge's counters
  (:meth:`Bridge.counters`), over a Unix socket on the host.

with-vcan describes both in ``$MSTC_VCAN_BRIDGE`` (JSON: ``iface``, ``bus`` as
``HOST:PORT``, ``control`` the socket's path) for the command it runs.
"""

from __future__ import annotations

import json
import os
import re
import select
import signal
import socket
import sys
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any

import can

from mstc.errors import BusError

ENV = "MSTC_VCAN_BRIDGE"
"""The variable with-vcan --bridge sets for its command."""
_LINE_END = re.compile(rb"[\r\a]")
CONNECT_TIMEOUT_S = 30.0
"""How long a control request waits for the control line (the guest agent
takes one client at a time) [s]."""


@dataclass(frozen=True)
class Bridge:
    """The bridge with-vcan made: the guest's interface, the bus's TCP end,
    the control socket."""

    iface: str
    host: str
    port: int
    control: Path

    @classmethod
    def from_env(cls, channel: str | None = None) -> Bridge | None:
        """The bridge of ``$MSTC_VCAN_BRIDGE``, when it is set and (with
        @p channel) bridges that interface; else None.

        :raises BusError: the variable is malformed.
        """
        text = os.environ.get(ENV)
        if not text:
            return None
        try:
            doc = json.loads(text)
            host, port = str(doc["bus"]).rsplit(":", 1)
            bridge = cls(str(doc["iface"]), host, int(port), Path(doc["control"]))
        except (ValueError, KeyError, TypeError) as exc:
            raise BusError(f"${ENV} is malformed ({exc}): {text!r}") from exc
        return bridge if channel is None or channel == bridge.iface else None

    def open_bus(self) -> BridgeBus:
        """The bus, as a python-can bus named after the guest's interface."""
        return BridgeBus(self.iface, address=(self.host, self.port))

    def counters(self) -> dict[str, int]:
        """The guest bridge's counters since it started (tools/vm/can-bridge.c:
        ``to_vcan``, ``to_host``, ``vcan_failed``, ``host_rejected``,
        ``host_dropped``, ``closed``, ...).

        :raises BusError: the guest agent did not answer.
        """
        with _Control(self.control) as ctl:
            ctl.send({"op": "stats"})
            answer = ctl.receive(10.0)
        stats = answer.get("stats") if answer else None
        if not isinstance(stats, dict):
            raise BusError(f"the vcan VM's agent gave no counters: {answer!r}")
        return {str(k): int(v) for k, v in stats.items()}

    def tally(self, bus: BridgeBus, before: dict[str, int], timeout: float = 5.0) -> dict[str, int]:
        """What crossed the bridge since @p before (its counters then, taken
        before anything was sent), once the firmware has stopped: every
        frame @p bus sent and what reached vcan0, every frame the guest took
        from vcan0 and what reached @p bus (read off the bus now, up to
        @p timeout [s], so that frames still on their way are not counted as
        lost), and the differences, which a correct run leaves at 0.

        :raises BusError: the agent did not answer.
        """
        bus.flush_tx_buffer()
        deadline = time.monotonic() + timeout
        while True:
            now = self.counters()
            delta = {k: v - before.get(k, 0) for k, v in now.items()}
            if delta["to_vcan"] + delta["vcan_failed"] >= bus.sent or time.monotonic() > deadline:
                break
            time.sleep(0.05)
        while bus.received < delta["to_host"] and time.monotonic() < deadline:
            bus.recv(max(deadline - time.monotonic(), 0.0))
        return {
            "to_firmware": bus.sent,
            "reached_vcan": delta["to_vcan"],
            "from_firmware": delta["to_host"],
            "reached_plant": bus.received,
            "dropped_to_vcan": bus.sent - delta["to_vcan"],
            "dropped_to_plant": delta["to_host"] - bus.received + delta["host_dropped"],
            "rejected": delta["host_rejected"],
        }

    @staticmethod
    def _vm_processes() -> Iterator[tuple[Path, list[str]]]:
        """(/proc/PID, the fields of its stat after the name) of each process
        of the VM: with-vcan names their process group in
        ``$MSTC_VCAN_VM_PGID``."""
        pgid = os.environ.get("MSTC_VCAN_VM_PGID")
        if not pgid:
            return
        for stat in Path("/proc").glob("[0-9]*/stat"):
            try:
                fields = stat.read_text().rsplit(")", 1)[1].split()
            except (OSError, IndexError):
                continue
            if fields[2] == pgid:  # the process group
                yield stat.parent, fields

    @classmethod
    def vm_threads(cls) -> list[int]:
        """The threads of the VM's processes (QEMU's vCPU, its main loop...)."""
        threads: list[int] = []
        for proc, _ in cls._vm_processes():
            try:
                threads += [int(t.name) for t in (proc / "task").iterdir()]
            except OSError:
                continue
        return threads

    @classmethod
    def vm_cpu_s(cls) -> float | None:
        """CPU time [s] the VM's processes have used, or None outside with-vcan
        --bridge's VM."""
        if not os.environ.get("MSTC_VCAN_VM_PGID"):
            return None
        ticks = sum(int(f[11]) + int(f[12]) for _, f in cls._vm_processes())  # utime, stime
        return ticks / os.sysconf("SC_CLK_TCK")

    def runner(self) -> list[str]:
        """The command that runs the command after it in the guest (:func:`run`)."""
        return [sys.executable, "-m", "mstc.can.vmbridge", "run", "--"]


class _Control:
    """One connection to the guest agent: JSON lines both ways."""

    def __init__(self, path: Path) -> None:
        deadline = time.monotonic() + CONNECT_TIMEOUT_S
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        while True:
            try:
                self.sock.connect(str(path))
                break
            except OSError as exc:
                if time.monotonic() > deadline:
                    self.sock.close()
                    raise BusError(f"cannot reach the vcan VM's agent at {path}: {exc}") from exc
                time.sleep(0.1)
        self._buf = b""

    def __enter__(self) -> _Control:
        return self

    def __exit__(self, *exc: object) -> None:
        self.sock.close()

    def send(self, doc: dict[str, Any]) -> None:
        self.sock.sendall(json.dumps(doc).encode() + b"\n")

    def receive(self, timeout: float | None) -> dict[str, Any] | None:
        """The next message; None at @p timeout [s] or when the line closed."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while b"\n" not in self._buf:
            left = None if deadline is None else max(deadline - time.monotonic(), 0.0)
            ready, _, _ = select.select([self.sock], [], [], left)
            if not ready:
                return None
            chunk = self.sock.recv(4096)
            if not chunk:
                return None
            self._buf += chunk
        line, self._buf = self._buf.split(b"\n", 1)
        doc = json.loads(line)
        return doc if isinstance(doc, dict) else None


class BridgeBus(can.BusABC):
    """The host's end of the bridge: slcan lines over TCP, as python-can's
    ``slcan`` interface speaks them, with two differences that matter on a
    busy machine:

    - what is sent waits in a buffer until the bus is next read (or
      :meth:`flush_tx_buffer`): the frames a plant sends for one step leave in
      one write, so the emulated side wakes once for them and a command with
      its PARAM_AUTH cannot be split over two control periods;
    - received bytes are read in blocks, not one system call per byte.

    :param channel: the name of the bus (the guest's interface).
    :param address: (host, port) of the bridge's TCP end.
    """

    def __init__(self, channel: str, address: tuple[str, int], **kwargs: Any) -> None:
        try:
            self._sock = socket.create_connection(address, timeout=10.0)
        except OSError as exc:
            raise can.CanInitializationError(
                f"cannot reach the vcan VM's bridge at {address[0]}:{address[1]}: {exc}"
            ) from exc
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._sock.setblocking(False)
        self._out = bytearray(b"O\r")  # open the channel (an adapter's command)
        self._in = b""
        self._lines: list[tuple[float, bytes]] = []
        """Lines received, each with the time its block arrived (the epoch)."""
        self.sent = 0
        """Frames sent since the start."""
        self.received = 0
        """Frames received since the start."""
        self.channel_info = f"vcan VM bridge {address[0]}:{address[1]} -> {channel}"
        super().__init__(channel=channel, **kwargs)
        self.flush_tx_buffer()

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        """Queue @p msg; it goes out when the bus is next read."""
        if msg.is_extended_id or msg.is_remote_frame or msg.is_fd or msg.dlc > 8:
            raise can.CanOperationError(f"the bridge carries classic 11-bit data frames: {msg}")
        self._out += b"t%03X%d%s\r" % (msg.arbitration_id, msg.dlc, msg.data.hex().upper().encode())
        self.sent += 1

    def flush_tx_buffer(self) -> None:
        """Send what waits."""
        if not self._out:
            return
        try:
            self._sock.setblocking(True)
            self._sock.sendall(self._out)
        except OSError as exc:
            raise can.CanOperationError(f"the vcan VM's bridge: {exc}") from exc
        finally:
            self._sock.setblocking(False)
        self._out.clear()

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        self.flush_tx_buffer()
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self._lines:
            left = None if deadline is None else max(deadline - time.monotonic(), 0.0)
            ready, _, _ = select.select([self._sock], [], [], left)
            if ready:
                try:
                    chunk = self._sock.recv(65536)
                except BlockingIOError:
                    chunk = None
                if chunk == b"":
                    raise can.CanOperationError("the vcan VM's bridge closed the connection")
                if chunk:
                    arrived = time.time()
                    # CR ends a line, and so does BEL (the answer to what
                    # could not be done).
                    *lines, self._in = _LINE_END.split(self._in + chunk)
                    self._lines += [(arrived, line) for line in lines]
            if deadline is not None and time.monotonic() >= deadline and not self._lines:
                return None, False
        arrived, line = self._lines.pop(0)
        while line[:1] != b"t":  # replies to commands (CR, BEL): nothing to receive
            if not self._lines:
                return None, False
            arrived, line = self._lines.pop(0)
        try:
            dlc = int(line[4:5])
            msg = can.Message(
                arbitration_id=int(line[1:4], 16),
                is_extended_id=False,
                dlc=dlc,
                data=bytes.fromhex(line[5 : 5 + 2 * dlc].decode()),
                timestamp=arrived,
                channel=self.channel_info,
            )
        except ValueError as exc:
            raise can.CanOperationError(f"the vcan VM's bridge sent {line!r}") from exc
        self.received += 1
        return msg, False

    def fileno(self) -> int:
        return self._sock.fileno()

    def shutdown(self) -> None:
        try:
            self._out += b"C\r"  # close the channel
            self.flush_tx_buffer()
        except can.CanError:
            pass
        finally:
            self._sock.close()
            super().shutdown()


# ------------------------------------------------------- running in the guest


def run(argv: Sequence[str]) -> int:
    """Run @p argv in the guest with this process's environment and working
    directory; its stdout and stderr come here line by line, SIGTERM and
    SIGINT go to it, and its exit status is returned (128 + N for a signal).

    :raises BusError: no bridge, or the agent did not start it.
    """
    bridge = Bridge.from_env()
    if bridge is None:
        raise BusError(f"${ENV} is not set: run under tools/vm/with-vcan --bridge")
    with _Control(bridge.control) as ctl:
        ctl.send({"op": "run", "argv": list(argv), "cwd": os.getcwd(), "env": dict(os.environ)})
        pending: list[int] = []

        def forward(sig: int, _frame: FrameType | None) -> None:
            pending.append(sig)

        signal.signal(signal.SIGTERM, forward)
        signal.signal(signal.SIGINT, forward)
        while True:
            while pending:
                ctl.send({"op": "signal", "signal": pending.pop(0)})
            try:
                msg = ctl.receive(0.2)
            except InterruptedError:
                continue
            if msg is None:
                if _closed(ctl.sock):
                    raise BusError("the vcan VM's agent went away")
                continue
            if "out" in msg:
                print(msg["out"], flush=True)
            elif "err" in msg:
                print(msg["err"], file=sys.stderr, flush=True)
            elif "exit" in msg:
                return int(msg["exit"])
            elif "error" in msg:
                raise BusError(f"the vcan VM's agent: {msg['error']}")


def _closed(sock: socket.socket) -> bool:
    try:
        return sock.recv(1, socket.MSG_PEEK | socket.MSG_DONTWAIT) == b""
    except BlockingIOError:
        return False


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m mstc.can.vmbridge run -- CMD...`` (:func:`run`) and
    ``python -m mstc.can.vmbridge stats``."""
    args = list(sys.argv[1:] if argv is None else argv)
    try:
        if args[:2] == ["run", "--"] and len(args) > 2:
            return run(args[2:])
        if args == ["stats"]:
            bridge = Bridge.from_env()
            if bridge is None:
                raise BusError(f"${ENV} is not set: run under tools/vm/with-vcan --bridge")
            print(json.dumps(bridge.counters()))
            return 0
    except BusError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 125
    print("usage: python -m mstc.can.vmbridge run -- CMD [ARGS...] | stats", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
