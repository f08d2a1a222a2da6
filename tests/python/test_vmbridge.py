# SPDX-License-Identifier: MIT
"""mstc.can.vmbridge's BridgeBus, the host's end of the vcan VM's bridge,
against a TCP peer here (no VM): it speaks slcan as python-can's own slcan
interface does (the expected bytes and messages come from python-can's
slcanBus over pyserial's loop:// port, not from the code under test), sends
a step's frames in one write when the bus is next read, and reads what comes
in blocks. The guest's end (tools/vm/can-bridge.c) is exercised with it in
test_hil.py, in the VM."""

from __future__ import annotations

import json
import socket
import time
from collections.abc import Iterator

import can
import pytest

from mstc.can.vmbridge import ENV, Bridge, BridgeBus
from mstc.errors import BusError

FRAMES = [
    can.Message(arbitration_id=0x100, data=bytes.fromhex("0123456789abcdef"), is_extended_id=False),
    can.Message(arbitration_id=0x7FF, data=b"", is_extended_id=False),
    can.Message(arbitration_id=0x000, data=b"\xff", is_extended_id=False),
    can.Message(arbitration_id=0x185, data=bytes.fromhex("6c0001"), is_extended_id=False),
]


def python_can_lines(messages: list[can.Message]) -> bytes:
    """What python-can's slcan interface writes for @p messages after opening
    the channel: its own bytes, read back through pyserial's loop:// port."""
    bus = can.Bus(interface="slcan", channel="loop://", sleep_after_open=0)
    try:
        port = bus.serialPortOrig  # type: ignore[attr-defined]
        port.reset_input_buffer()
        for msg in messages:
            bus.send(msg)
        time.sleep(0.05)
        return bytes(port.read(port.in_waiting))
    finally:
        bus.shutdown()


@pytest.fixture
def peer() -> Iterator[tuple[socket.socket, BridgeBus]]:
    """A BridgeBus connected to a socket here (the guest's end)."""
    server = socket.create_server(("127.0.0.1", 0))
    bus = BridgeBus("vcan0", address=server.getsockname()[:2])
    conn, _ = server.accept()
    conn.settimeout(2.0)
    try:
        yield conn, bus
    finally:
        bus.shutdown()
        conn.close()
        server.close()


def read_available(conn: socket.socket, wait: float = 0.2) -> bytes:
    conn.settimeout(wait)
    out = b""
    try:
        while chunk := conn.recv(65536):
            out += chunk
    except TimeoutError:
        pass
    return out


def test_the_bridge_bus_opens_the_channel_and_sends_as_python_can_does(
    peer: tuple[socket.socket, BridgeBus],
) -> None:
    conn, bus = peer
    assert read_available(conn) == b"O\r"  # python-can's open command too
    for msg in FRAMES:
        bus.send(msg)
    assert read_available(conn) == b"", "sent before the bus was read"
    assert bus.recv(0.0) is None  # reading flushes
    got = read_available(conn)
    assert got == python_can_lines(FRAMES)
    assert bus.sent == len(FRAMES)


def test_the_bridge_bus_receives_what_python_can_would_send(
    peer: tuple[socket.socket, BridgeBus],
) -> None:
    conn, bus = peer
    lines = python_can_lines(FRAMES)
    # Split anywhere, with command replies (CR, BEL) between frames.
    stream = b"\r\a" + lines[:7] + lines[7:]
    conn.sendall(stream[:5])
    conn.sendall(stream[5:])
    got = [bus.recv(2.0) for _ in FRAMES]
    assert [(m.arbitration_id, bytes(m.data), m.dlc) for m in got if m] == [
        (m.arbitration_id, bytes(m.data), m.dlc) for m in FRAMES
    ]
    assert bus.recv(0.1) is None
    assert bus.received == len(FRAMES)
    assert all(m is not None and abs(m.timestamp - time.time()) < 5 for m in got)


def test_the_bridge_bus_refuses_what_the_bridge_cannot_carry(
    peer: tuple[socket.socket, BridgeBus],
) -> None:
    _, bus = peer
    with pytest.raises(can.CanOperationError, match="11-bit"):
        bus.send(can.Message(arbitration_id=0x1ABCDE0F, is_extended_id=True))


def test_bridge_from_env(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(ENV, raising=False)
    assert Bridge.from_env("vcan0") is None
    doc = {"iface": "vcan0", "bus": "127.0.0.1:4321", "control": "/tmp/x/ctl.sock"}
    monkeypatch.setenv(ENV, json.dumps(doc))
    bridge = Bridge.from_env("vcan0")
    assert bridge is not None and (bridge.host, bridge.port) == ("127.0.0.1", 4321)
    assert Bridge.from_env("can0") is None  # another interface: not bridged
    monkeypatch.setenv(ENV, "{not json")
    with pytest.raises(BusError, match="malformed"):
        Bridge.from_env()
