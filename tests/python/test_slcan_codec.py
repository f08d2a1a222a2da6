# SPDX-License-Identifier: MIT
"""The firmware's slcan line codec against python-can's own slcan interface.

The board images built with CAN=slcan speak the Lawicel protocol on a UART
(hal/stm32/slcan.c); the host end in `make pil` is python-can 4.6.1's
``slcan`` interface. Here both meet without a board: python-can's slcanBus
runs on pyserial's ``loop://`` port, whose writes come back as reads, and the
codec (hal/stm32/slcan_codec.c) runs on the host through
tests/codec/slcan_shim.c, compiled with the project's warnings.

- Encoder: every frame python-can's ``send`` writes (every DLC 0..8, standard
  ids 0x000 and 0x7FF and random ones, random data) the codec parses into the
  same frame, answering ``z``; the ``O`` python-can opens with opens the
  channel.
- Decoder: every line the codec formats for a frame the firmware sends,
  python-can's ``recv`` reads back as the same message.
- Malformed lines (bad hex, wrong lengths, ids beyond 11 bits, over-long
  lines, random bytes) are answered with BEL and give no frame; any line the
  codec does take as a frame, python-can decodes to the same frame.

A missing compiler fails the tests; they never skip.
"""

from __future__ import annotations

import ctypes
import random
import time
from collections.abc import Iterator
from pathlib import Path

import can
import pytest
import serial

from conftest import build_shim

SOURCES = ["tests/codec/slcan_shim.c", "hal/stm32/slcan_codec.c"]
SEED = 14
REPLY_MAX = 6
FRAME_LINE_MAX = 22
BEL = b"\x07"
S6 = 6  # Lawicel's code of 500 kbit/s
IDS = [0x000, 0x7FF, 0x001, 0x100, 0x123, 0x400, 0x7FE]


class Codec:
    """ctypes binding of tests/codec/slcan_shim.c."""

    def __init__(self, path: Path) -> None:
        lib = ctypes.CDLL(str(path))
        lib.slcan_shim_init.argtypes = [ctypes.c_uint8]
        lib.slcan_shim_open.restype = ctypes.c_int
        lib.slcan_shim_feed.restype = ctypes.c_int
        lib.slcan_shim_feed.argtypes = [
            ctypes.c_char_p,
            ctypes.c_size_t,
            ctypes.POINTER(ctypes.c_int),
            ctypes.POINTER(ctypes.c_uint32),
            ctypes.POINTER(ctypes.c_uint8),
            ctypes.POINTER(ctypes.c_uint8),
            ctypes.c_char_p,
            ctypes.POINTER(ctypes.c_uint8),
        ]
        lib.slcan_shim_format.restype = ctypes.c_size_t
        lib.slcan_shim_format.argtypes = [
            ctypes.c_uint32,
            ctypes.c_uint8,
            ctypes.c_char_p,
            ctypes.c_char_p,
        ]
        self.lib = lib

    def init(self) -> None:
        self.lib.slcan_shim_init(S6)

    @property
    def open(self) -> bool:
        return bool(self.lib.slcan_shim_open())

    def feed(self, data: bytes) -> tuple[int, can.Message | None, bytes]:
        """Feed @p data: (commands completed, the last one's frame or None,
        its reply)."""
        has = ctypes.c_int(0)
        fid = ctypes.c_uint32(0)
        dlc = ctypes.c_uint8(0)
        payload = (ctypes.c_uint8 * 8)()
        reply = ctypes.create_string_buffer(REPLY_MAX)
        n = ctypes.c_uint8(0)
        lines = self.lib.slcan_shim_feed(
            data, len(data), has, fid, dlc, payload, reply, ctypes.byref(n)
        )
        frame = None
        if has.value:
            frame = can.Message(
                arbitration_id=fid.value,
                is_extended_id=False,
                dlc=dlc.value,
                data=bytes(payload)[: dlc.value],
            )
        return lines, frame, reply.raw[: n.value]

    def format(self, msg: can.Message) -> bytes:
        out = ctypes.create_string_buffer(FRAME_LINE_MAX)
        data = bytes(msg.data).ljust(8, b"\0")
        n = self.lib.slcan_shim_format(msg.arbitration_id, msg.dlc, data, out)
        return out.raw[:n]


@pytest.fixture(scope="module")
def codec(tmp_path_factory: pytest.TempPathFactory) -> Codec:
    return Codec(build_shim(SOURCES, tmp_path_factory.mktemp("slcan") / "libslcan.so", "slcan"))


@pytest.fixture
def bus() -> Iterator[can.BusABC]:
    """python-can's slcan interface on a loop-back port: what it writes can be
    read back, and what is written into the port it receives."""
    with can.Bus(interface="slcan", channel="loop://", sleep_after_open=0) as b:
        yield b


def _port(bus: can.BusABC) -> serial.SerialBase:
    """The pyserial port under python-can's slcanBus."""
    return bus.serialPortOrig  # type: ignore[attr-defined]


def _written(bus: can.BusABC) -> bytes:
    """What python-can has written to the port so far: its lines, up to the
    last CR (pyserial's loop:// hands the bytes back one by one)."""
    port = _port(bus)
    data = b""
    deadline = time.monotonic() + 2.0
    while port.in_waiting or not data.endswith(b"\r"):
        data += port.read(max(port.in_waiting, 1))
        if time.monotonic() > deadline:
            break
    return data


def _same(a: can.Message, b: can.Message) -> bool:
    return (
        a.arbitration_id == b.arbitration_id
        and a.is_extended_id == b.is_extended_id
        and not a.is_remote_frame
        and not b.is_remote_frame
        and a.dlc == b.dlc
        and bytes(a.data) == bytes(b.data)
    )


def _frames() -> Iterator[can.Message]:
    """Every DLC with each id of IDS, then seeded random ones."""
    rng = random.Random(SEED)
    for fid in IDS:
        for dlc in range(9):
            yield can.Message(
                arbitration_id=fid, is_extended_id=False, data=rng.randbytes(dlc), dlc=dlc
            )
    for _ in range(300):
        dlc = rng.randrange(9)
        yield can.Message(
            arbitration_id=rng.randrange(0x800),
            is_extended_id=False,
            data=rng.randbytes(dlc),
            dlc=dlc,
        )


def test_python_can_opens_the_channel_the_lawicel_way(codec: Codec, bus: can.BusABC) -> None:
    codec.init()
    opening = _written(bus)
    assert opening == b"O\r"  # python-can 4.6.1 without a bit rate: open only
    lines, frame, reply = codec.feed(opening)
    assert (lines, frame, reply) == (1, None, b"\r")
    assert codec.open


def test_every_frame_python_can_sends_is_parsed_to_the_same_frame(
    codec: Codec, bus: can.BusABC
) -> None:
    codec.init()
    codec.feed(_written(bus))
    for msg in _frames():
        bus.send(msg)
        line = _written(bus)
        lines, frame, reply = codec.feed(line)
        assert lines == 1, line
        assert frame is not None and _same(frame, msg), (line, frame)
        assert reply == b"z\r", line


def test_every_line_the_firmware_formats_python_can_reads_as_the_frame(
    codec: Codec, bus: can.BusABC
) -> None:
    _written(bus)  # python-can's own O
    port = _port(bus)
    for msg in _frames():
        line = codec.format(msg)
        assert len(line) == 6 + 2 * msg.dlc and line.endswith(b"\r")
        port.write(line)
        got = bus.recv(timeout=1.0)
        assert got is not None and _same(got, msg), (line, got)


MALFORMED = [
    b"t8000",  # id beyond 11 bits
    b"tFFF0",
    b"t1239",  # DLC 9
    b"t123",  # no DLC
    b"t12",
    b"t",
    b"t1232AB",  # one data byte short
    b"t1231ABCD",  # one long
    b"t12G0",  # not hexadecimal
    b"t1231GG",
    b"t123-1",
    b"t 1230",
    b"T200000000",  # id beyond 29 bits
    b"T1234567",
    b"r12381",  # a remote frame with data
    b"d1230",  # CAN FD: not offered
    b"Z1",
    b"s011C",
    b"O1",
    b"X",
    b"t1238" + b"00" * 8 + b"00",
    b"t" + b"0" * 40,  # longer than any command
    b"\x00\xff\x80",
]


@pytest.mark.parametrize("line", MALFORMED, ids=[repr(m) for m in MALFORMED])
def test_malformed_lines_get_bel_and_no_frame(codec: Codec, line: bytes) -> None:
    codec.init()
    assert codec.feed(b"O\r")[2] == b"\r"
    assert codec.feed(line + b"\r") == (1, None, BEL)
    # The channel still works.
    lines, frame, reply = codec.feed(b"t7FF1AA\r")
    assert frame is not None and frame.arbitration_id == 0x7FF and reply == b"z\r"


def test_random_lines_never_crash_and_frames_agree_with_python_can(
    codec: Codec, bus: can.BusABC
) -> None:
    """Seeded random lines, from the alphabet of commands and beyond: each is
    answered (a reply or, for an empty line, nothing); a frame comes only with
    z, and python-can's decoder reads the same line to the same frame."""
    rng = random.Random(SEED)
    alphabet = b"tTrRSOCVN0123456789ABCDEFabcdefgG \n\x07\xff"
    codec.init()
    codec.feed(b"O\r")
    _written(bus)
    frames = 0
    for _ in range(10000):
        if rng.random() < 0.5:  # near-valid: a t command with one thing changed
            dlc = rng.randrange(9)
            text = f"t{rng.randrange(0x800):03X}{dlc}{rng.randbytes(dlc).hex()}"
            line = bytearray(text.encode())
            i = rng.randrange(len(line))
            line[i] = rng.choice(alphabet)
        else:
            line = bytearray(rng.choice(alphabet) for _ in range(rng.randrange(30)))
        line = bytes(line).replace(b"\r", b"")
        if line.startswith(b"C") and len(line) == 1:
            continue  # would close the channel
        lines, frame, reply = codec.feed(line + b"\r")
        assert lines == 1
        if frame is not None:
            frames += 1
            assert reply == b"z\r"
            _port(bus).write(line + b"\r")
            got = bus.recv(timeout=1.0)
            assert got is not None and _same(got, frame), (line, got, frame)
        else:
            assert reply in (BEL, b"\r", b"Z\r", b"z\r", b"V0101\r", b"NMSTC\r", b""), line
        if not codec.open:
            codec.feed(b"O\r")
    assert frames > 500  # the near-valid half is often valid
