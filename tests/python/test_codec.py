# SPDX-License-Identifier: MIT
"""The C codec and protocol adapter against cantools and the plant's protocol.py.

- The generated C codec (firmware/comm/mstc_dbc.c) packs and unpacks every
  message of mstc.dbc bit-exactly as cantools' Python encode and decode do, on
  seeded random raw values and random payloads.
- The firmware's adapter (firmware/comm/comm.c) and the plant's
  (sim/mstc/can/protocol.py) agree: same bytes for the same values (scaling,
  rounding, saturation, alive counter, CRC; protocol.py saturates like comm.c
  only when asked, with ``saturate=True``), and the firmware decodes the
  plant's frames to the values cantools reads from them; both drop the same
  frames for the same reasons.
- comm.c's data IDs and frame directions are those of the DBC.

The C side is reached through tests/codec/codec_shim.c, which this module
compiles with the project's warnings (float mode) into a shared library. A
missing compiler fails the tests; it never skips them.
"""

from __future__ import annotations

import ctypes
import errno
import math
import random
import struct
from collections.abc import Callable
from pathlib import Path

import can
import pytest
from cantools.database.can import Message, Signal
from cantools.database.can.c_source import camel_to_snake_case

from conftest import AUTH_SOURCES, build_shim
from mstc.can.protocol import DLC, DropReason, Protocol, load_database
from mstc.errors import FrameDropped

ROOT = Path(__file__).resolve().parents[2]
SEED = 4
N_RANDOM = 400
"""Random cases per message and property."""
SOURCES = [
    "tests/codec/codec_shim.c",
    "firmware/comm/comm.c",
    "firmware/comm/mstc_dbc.c",
    *AUTH_SOURCES,
]

DB = load_database()
MESSAGES = sorted(DB.messages, key=lambda m: m.frame_id)
FW_SENT = [m for m in MESSAGES if "FW" in m.senders]
FW_RECEIVED = [m for m in MESSAGES if "FW" in m.receivers]
FW_ONLY_SENT = [m for m in FW_SENT if m not in FW_RECEIVED]
"""Frames the firmware sends and does not receive (WHEEL_SPEED it does both)."""
ERRNO_OF = {
    DropReason.UNKNOWN: -errno.ENOENT,
    DropReason.LENGTH: -errno.EMSGSIZE,
    DropReason.CRC: -errno.EBADMSG,
}
SEQUENCE_ERRNOS = (-errno.EALREADY, -errno.ERANGE)


def _ids(messages: list[Message]) -> list[str]:
    return [m.name for m in messages]


# ------------------------------------------------------------------- the shim


class Shim:
    """ctypes binding of tests/codec/codec_shim.c."""

    def __init__(self, path: Path) -> None:
        lib = ctypes.CDLL(str(path))
        u8p = ctypes.POINTER(ctypes.c_uint8)
        dp = ctypes.POINTER(ctypes.c_double)
        sig: dict[str, tuple[type | None, list[type]]] = {
            "shim_n_messages": (ctypes.c_int, []),
            "shim_message_id": (ctypes.c_uint32, [ctypes.c_int]),
            "shim_n_fields": (ctypes.c_int, [ctypes.c_uint32]),
            "shim_field_name": (ctypes.c_char_p, [ctypes.c_uint32, ctypes.c_int]),
            "shim_pack": (ctypes.c_int, [ctypes.c_uint32, dp, u8p]),
            "shim_unpack": (ctypes.c_int, [ctypes.c_uint32, u8p, dp]),
            "shim_comm_init": (None, []),
            "shim_data_id": (ctypes.c_int, [ctypes.c_uint32]),
            "shim_comm_drops": (None, [ctypes.POINTER(ctypes.c_uint)]),
            "shim_comm_encode": (ctypes.c_int, [ctypes.c_uint32, dp, u8p]),
            "shim_comm_decode": (ctypes.c_int, [ctypes.c_uint32, ctypes.c_uint8, u8p, dp]),
        }
        for name, (restype, argtypes) in sig.items():
            fn = getattr(lib, name)
            fn.restype = restype
            fn.argtypes = argtypes
        self.lib = lib

    def field_names(self, frame_id: int) -> list[str]:
        n = self.lib.shim_n_fields(frame_id)
        assert n >= 0, f"the shim has no message 0x{frame_id:03X}"
        return [self.lib.shim_field_name(frame_id, i).decode() for i in range(n)]

    def pack(self, frame_id: int, values: list[float]) -> bytes:
        out = (ctypes.c_uint8 * DLC)()
        rc = self.lib.shim_pack(frame_id, (ctypes.c_double * len(values))(*values), out)
        assert rc == DLC, f"pack of 0x{frame_id:03X} returned {rc}"
        return bytes(out)

    def unpack(self, frame_id: int, data: bytes, n: int) -> list[float]:
        out = (ctypes.c_double * n)()
        rc = self.lib.shim_unpack(frame_id, (ctypes.c_uint8 * DLC)(*data), out)
        assert rc == 0, f"unpack of 0x{frame_id:03X} returned {rc}"
        return list(out)

    def comm_encode(self, frame_id: int, inputs: list[float]) -> bytes:
        out = (ctypes.c_uint8 * DLC)()
        rc = self.lib.shim_comm_encode(frame_id, (ctypes.c_double * len(inputs))(*inputs), out)
        assert rc == 0, f"comm_encode of 0x{frame_id:03X} returned {rc}"
        return bytes(out)

    def comm_decode(self, msg: can.Message) -> tuple[int, list[float]]:
        out = (ctypes.c_double * 4)()
        data = (ctypes.c_uint8 * DLC)(*bytes(msg.data)[:DLC])
        rc = self.lib.shim_comm_decode(msg.arbitration_id, msg.dlc, data, out)
        return rc, list(out)

    def drops(self) -> list[int]:
        out = (ctypes.c_uint * 4)()
        self.lib.shim_comm_drops(out)
        return list(out)


@pytest.fixture(scope="session")
def shim(tmp_path_factory: pytest.TempPathFactory) -> Shim:
    """The shim, compiled once per session with the project's warnings."""
    lib = build_shim(SOURCES, tmp_path_factory.mktemp("codec") / "libcodec_shim.so", "codec")
    return Shim(lib)


# ---------------------------------------------------------------- random data


def _f32(x: float) -> float:
    """@p x rounded to IEEE single, as the firmware receives it."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def _field_range(signal: Signal) -> tuple[int, int]:
    if signal.is_signed:
        return -(1 << (signal.length - 1)), (1 << (signal.length - 1)) - 1
    return 0, (1 << signal.length) - 1


def _random_raw(rng: random.Random, signal: Signal) -> float | int:
    """A raw value the signal's bits hold, ends included more often than chance."""
    if signal.is_float:
        while True:
            x = struct.unpack("<f", rng.randbytes(4))[0]
            if not math.isnan(x):
                return x
    lo, hi = _field_range(signal)
    return rng.choice([lo, hi, 0, rng.randint(lo, hi), rng.randint(lo, hi), rng.randint(lo, hi)])


def _random_phys(rng: random.Random, signal: Signal, over: float = 0.25) -> float:
    """A physical value (float32) around the signal's range, up to @p over of
    its span beyond each end, off the raw grid by a random fraction. IEEE
    float signals get any finite or infinite single."""
    if signal.is_float:
        return float(_random_raw(rng, signal))
    lo, hi = signal.minimum, signal.maximum
    span = hi - lo
    pick = rng.random()
    if pick < 0.1:
        x = lo - rng.random() * over * span
    elif pick < 0.2:
        x = hi + rng.random() * over * span
    elif pick < 0.3:
        # A half-way point between two raw values: rounding ties.
        x = (rng.randint(-1000, 1000) + 0.5) * signal.scale
    else:
        x = lo + rng.random() * span
    return _f32(x)


# ------------------------------------------------------- the generated codec


def test_shim_covers_every_message_of_the_dbc_in_signal_order(shim: Shim) -> None:
    assert shim.lib.shim_n_messages() == len(MESSAGES)
    ids = {shim.lib.shim_message_id(i) for i in range(shim.lib.shim_n_messages())}
    assert ids == {m.frame_id for m in MESSAGES}
    for m in MESSAGES:
        assert shim.field_names(m.frame_id) == [camel_to_snake_case(s.name) for s in m.signals]


@pytest.mark.parametrize("message", MESSAGES, ids=_ids(MESSAGES))
def test_c_pack_is_cantools_encode(shim: Shim, message: Message) -> None:
    rng = random.Random(f"{SEED}-pack-{message.name}")
    for _ in range(N_RANDOM):
        raw = {s.name: _random_raw(rng, s) for s in message.signals}
        want = message.encode(raw, scaling=False, strict=False)
        got = shim.pack(message.frame_id, [float(raw[s.name]) for s in message.signals])
        assert got.hex(" ") == want.hex(" "), f"{message.name} {raw}"


@pytest.mark.parametrize("message", MESSAGES, ids=_ids(MESSAGES))
def test_c_unpack_is_cantools_decode(shim: Shim, message: Message) -> None:
    rng = random.Random(f"{SEED}-unpack-{message.name}")
    payloads = [bytes(DLC), b"\xff" * DLC] + [rng.randbytes(DLC) for _ in range(N_RANDOM)]
    for data in payloads:
        want = message.decode(data, scaling=False, decode_choices=False)
        got = shim.unpack(message.frame_id, data, len(message.signals))
        for signal, value in zip(message.signals, got, strict=True):
            expected = want[signal.name]
            if signal.is_float and math.isnan(expected):
                assert math.isnan(value), f"{signal.name} of {data.hex()}"
            else:
                assert value == expected, f"{signal.name} of {data.hex()}"


# -------------------------------------------------- comm.c against the DBC


def test_comm_data_ids_are_the_dbc_attribute(shim: Shim) -> None:
    for m in MESSAGES:
        assert shim.lib.shim_data_id(m.frame_id) == m.dbc.attributes["E2EDataID"].value, m.name
    ids = [m.dbc.attributes["E2EDataID"].value for m in MESSAGES]
    assert len(set(ids)) == len(ids), "data IDs must be distinct"
    assert shim.lib.shim_data_id(0x7FF) == -errno.ENOENT


def _valid_values(rng: random.Random, message: Message) -> dict[str, float]:
    prefix = f"{message.name}_"
    return {
        s.name.removeprefix(prefix): _random_phys(rng, s, over=0.0)
        for s in message.signals
        if s.name not in (f"{prefix}CRC", f"{prefix}Counter")
    }


def test_comm_receives_exactly_the_frames_the_dbc_sends_it(shim: Shim) -> None:
    rng = random.Random(f"{SEED}-direction")
    shim.lib.shim_comm_init()
    tool = Protocol()
    for m in MESSAGES:
        rc, _ = shim.comm_decode(tool.encode(m.name, _valid_values(rng, m), saturate=True))
        assert rc == (0 if "FW" in m.receivers else -errno.ENOENT), m.name


# ------------------------------------------- comm.c against protocol.py


def _status(rng: random.Random) -> tuple[list[float], dict[str, float]]:
    mode, side, active = rng.randint(0, 5), rng.choice([-1, 0, 1]), rng.randint(0, 60)
    faults, frame_faults = rng.randint(0, 255), rng.randint(0, 1)
    e, distance, step = _f32(rng.uniform(-5, 5)), _f32(rng.uniform(-2, 70)), rng.randint(0, 65535)
    halt = rng.randint(0, 9)
    inputs = [mode, side, active, faults, e, distance, step, frame_faults, halt]
    # Bit 5: a value beyond its signal's DBC range went out clipped.
    status = DB.get_message_by_name("STATUS")
    clipped = any(
        not s.minimum <= x <= s.maximum
        for s, x in (
            (status.get_signal_by_name(f"STATUS_{n}"), v)
            for n, v in (("e", e), ("distance", distance))
        )
    )
    wire = {
        "mode": min(mode, 3),
        "side": {0: 0, 1: 1, -1: 2}[side],
        "obstacle": min(active, 48),  # COMM_OBSTACLE_ID_MAX
        "faults": (faults & 0x17) | (frame_faults << 3) | (0x20 if clipped else 0),
        "e": e,
        "distance": distance,
        "step": step & 0x7,
        "halt": min(halt, 7),
    }
    return inputs, wire


def _event(rng: random.Random) -> tuple[list[float], dict[str, float]]:
    kind, side, obstacle = rng.randint(1, 9), rng.choice([-1, 0, 1]), rng.randint(0, 60)
    t_us = rng.choice([0, rng.randint(0, 2**32 - 1), 2**32 - 1])
    inputs = [kind, side, obstacle, t_us]
    wire = {
        "kind": min(kind, 7),
        "side": {0: 0, 1: 1, -1: 2}[side],
        "obstacle": min(obstacle, 48),  # COMM_OBSTACLE_ID_MAX
        "time": t_us * 1e-6,
    }
    return inputs, wire


def _wheel_cmd(rng: random.Random) -> tuple[list[float], dict[str, float]]:
    step = rng.randint(0, 65535)
    s = DB.get_message_by_name("WHEEL_CMD").get_signal_by_name("WHEEL_CMD_left")
    left, right = _random_phys(rng, s), _random_phys(rng, s)
    return [step, left, right], {"step": step, "left": left, "right": right}


def _wheel_speed(rng: random.Random) -> tuple[list[float], dict[str, float]]:
    s = DB.get_message_by_name("WHEEL_SPEED").get_signal_by_name("WHEEL_SPEED_left")
    left, right = _random_phys(rng, s), _random_phys(rng, s)
    # A wheel loop's fault bits: four go on the wire, the rest are dropped.
    faults = rng.randint(0, 255)
    return [left, right, faults], {"left": left, "right": right, "faults": faults & 0xF}


def _status_trk(rng: random.Random) -> tuple[list[float], dict[str, float]]:
    m = DB.get_message_by_name("STATUS_TRK")
    e = [_random_phys(rng, m.get_signal_by_name(f"STATUS_TRK_e{i}")) for i in (1, 2, 3)]
    # The echoed ODOM_XY counter: its low 4 bits go on the wire.
    counter = rng.randint(0, 255)
    return [*e, counter], {"odom_counter": counter & 0xF, "e1": e[0], "e2": e[1], "e3": e[2]}


def _counters(rng: random.Random) -> tuple[list[float], dict[str, float]]:
    n = [rng.randint(0, 4095) for _ in range(4)]
    names = ("crc_errors", "seq_errors", "len_errors", "unknown_ids")
    return n, dict(zip(names, n, strict=True))


def _heartbeat(rng: random.Random) -> tuple[list[float], dict[str, float]]:
    state = rng.randint(0, 6)  # 5 and 6 saturate to fault (4)
    return [state], {"state": state}


def _param_value(rng: random.Random) -> tuple[list[float], dict[str, float]]:
    index, result = rng.randint(0, 12), rng.randint(0, 4)
    value = _random_raw(rng, DB.get_message_by_name("PARAM_VALUE").signals[-1])
    return [index, result, value], {"index": index, "result": result, "value": value}


def _auth_status(rng: random.Random) -> tuple[list[float], dict[str, float]]:
    last, refused, saturated = rng.randint(0, 6), rng.randint(0, 32767), rng.randint(0, 1)
    session = rng.choice([0, rng.randint(0, 2**32 - 1), 2**32 - 1])
    inputs = [last, session, refused, saturated]
    return inputs, {
        "last": last,
        "session": session,
        "refused": refused,
        "refused_saturated": saturated,
    }


def _auth_challenge(rng: random.Random) -> tuple[list[float], dict[str, float]]:
    """The status MAC is the tools' (secoc.status_mac, `cryptography`'s CMAC),
    under the all-zero key the shim gives the firmware's state."""
    from mstc.can import secoc

    inputs, wire = _auth_status(rng)
    freshness = rng.choice([0, rng.randint(0, 2**20 - 1), 2**20 - 1])
    status = secoc.Status(
        int(wire["session"]),
        freshness,
        int(wire["last"]),
        int(wire["refused"]),
        bool(wire["refused_saturated"]),
    )
    mac = int.from_bytes(secoc.status_mac(bytes(16), status), "little")
    return [*inputs, freshness], {"freshness": freshness, "mac": mac}


def _fw_version(rng: random.Random) -> tuple[list[float], dict[str, float]]:
    """Version fields beyond their bits saturate (4, 6 and 5 bits); the build
    id keeps its low 28 bits; node 0 (comm_init's), the protocol N of the
    DBC's VERSION line ("mstc N")."""
    major, minor, patch = rng.randint(0, 20), rng.randint(0, 70), rng.randint(0, 40)
    dirty, fixed, build = rng.randint(0, 1), rng.randint(0, 1), rng.randint(0, 2**32 - 1)
    return [major, minor, patch, dirty, build, fixed], {
        "node": 0,
        "numeric": fixed,
        "protocol": int(str(load_database().version).split()[1]),
        "major": min(major, 15),
        "minor": min(minor, 63),
        "patch": min(patch, 31),
        "dirty": dirty,
        "build": build & (2**28 - 1),
    }


CASES: dict[str, Callable[[random.Random], tuple[list[float], dict[str, float]]]] = {
    "WHEEL_CMD": _wheel_cmd,
    "WHEEL_SPEED": _wheel_speed,
    "STATUS": _status,
    "STATUS_TRK": _status_trk,
    "STATUS_COUNTERS": _counters,
    "EVENT": _event,
    "HEARTBEAT": _heartbeat,
    "AUTH_STATUS": _auth_status,
    "AUTH_CHALLENGE": _auth_challenge,
    "PARAM_VALUE": _param_value,
    "FW_VERSION": _fw_version,
}


def test_every_firmware_frame_has_a_case() -> None:
    assert set(CASES) == {m.name for m in FW_SENT}


@pytest.mark.parametrize("message", FW_SENT, ids=_ids(FW_SENT))
def test_comm_encode_is_protocol_encode(shim: Shim, message: Message) -> None:
    """Same bytes from comm.c and protocol.py, over more frames than the
    counter has values."""
    rng = random.Random(f"{SEED}-encode-{message.name}")
    shim.lib.shim_comm_init()
    fw = Protocol("FW")
    for i in range(N_RANDOM):
        inputs, wire = CASES[message.name](rng)
        got = shim.comm_encode(message.frame_id, inputs)
        want = bytes(fw.encode(message.name, wire, saturate=True).data)
        assert got.hex(" ") == want.hex(" "), f"frame {i}: inputs {inputs}"


@pytest.mark.parametrize("message", FW_RECEIVED, ids=_ids(FW_RECEIVED))
def test_comm_decodes_protocol_frames_to_cantools_values(shim: Shim, message: Message) -> None:
    rng = random.Random(f"{SEED}-decode-{message.name}")
    shim.lib.shim_comm_init()
    plant = Protocol(next(iter(message.senders)))
    prefix = f"{message.name}_"
    for _ in range(N_RANDOM):
        values = {
            s.name.removeprefix(prefix): _random_phys(rng, s)
            for s in message.signals
            if s.name not in (f"{prefix}CRC", f"{prefix}Counter")
        }
        msg = plant.encode(message.name, values, saturate=True)
        rc, got = shim.comm_decode(msg)
        assert rc == 0, f"{values}: {rc}"
        want = message.decode(bytes(msg.data), scaling=True, decode_choices=False)
        # The faults of a WHEEL_SPEED are a board's report to the tools; the
        # firmware does not read them.
        names = [s.name for s in message.signals[2:] if s.name != "WHEEL_SPEED_faults"]
        if message.name == "STEP":  # the firmware keeps the time in µs
            want[f"{prefix}time"] = round(want[f"{prefix}time"] * 1e6)
        if message.name == "OBSTACLE":
            # The radius is in cm, the one decimal resolution: the firmware's
            # float is the correctly rounded cm / 100, within half an ulp.
            radius = want[f"{prefix}radius"]
            assert got[3] == pytest.approx(radius, rel=2**-24, abs=0), f"{values}"
            want[f"{prefix}radius"] = got[3]
        assert got[: len(names)] == [want[n] for n in names], f"{values}"


def _corrupt(rng: random.Random, msg: can.Message) -> can.Message:
    """@p msg, or one of its faulty variants."""
    data = bytearray(msg.data)
    kind = rng.randrange(8)
    if kind == 0:  # a bit flipped anywhere, CRC and counter included
        data[rng.randrange(DLC)] ^= 1 << rng.randrange(8)
        return can.Message(arbitration_id=msg.arbitration_id, is_extended_id=False, data=data)
    if kind == 1:  # truncated
        n = rng.randrange(DLC)
        return can.Message(arbitration_id=msg.arbitration_id, is_extended_id=False, data=data[:n])
    if kind == 2:  # an identifier the firmware does not receive
        other = rng.choice([0x106, 0x7FF, *[m.frame_id for m in FW_ONLY_SENT]])
        return can.Message(arbitration_id=other, is_extended_id=False, data=data)
    return msg


def test_comm_and_protocol_drop_the_same_frames(shim: Shim) -> None:
    """A random stream of good, lost, repeated and damaged frames: comm.c and
    protocol.py (as the firmware node) accept and drop the same ones, for the
    same reasons, and count the same drops."""
    rng = random.Random(f"{SEED}-drops")
    shim.lib.shim_comm_init()
    senders = {"PLANT": Protocol("PLANT"), "TOOL": Protocol("TOOL")}
    fw = Protocol("FW")
    last: can.Message | None = None
    for i in range(20 * N_RANDOM):
        message = rng.choice(FW_RECEIVED)
        sender = senders[next(iter(message.senders))]
        if last is not None and rng.random() < 0.1:
            msg = last  # a repeat
        else:
            msg = sender.encode(message.name, _valid_values(rng, message), saturate=True)
            while rng.random() < 0.15:  # frames lost on the way
                msg = sender.encode(message.name, _valid_values(rng, message), saturate=True)
        last = msg
        msg = _corrupt(rng, msg)
        rc, _ = shim.comm_decode(msg)
        try:
            fw.check(msg)
        except FrameDropped as drop:
            if drop.reason is DropReason.SEQUENCE:
                assert rc in SEQUENCE_ERRNOS, f"frame {i}: {drop}, C {rc}"
            else:
                assert rc == ERRNO_OF[drop.reason], f"frame {i}: {drop}, C {rc}"
        else:
            assert rc == 0, f"frame {i}: accepted by protocol.py, C {rc}"
    drops = fw.drops
    want = [drops[DropReason.CRC], drops[DropReason.SEQUENCE], drops[DropReason.LENGTH]]
    assert shim.drops() == [*want, drops[DropReason.UNKNOWN]]
    assert all(n > 0 for n in shim.drops()), "every drop reason must occur"
