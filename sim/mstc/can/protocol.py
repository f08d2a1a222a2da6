# SPDX-License-Identifier: MIT
"""The CAN protocol of mstc (``firmware/comm/mstc.dbc``) for the plant and tools.

The Python counterpart of ``firmware/comm/comm.c``: every frame is classic CAN
with an 11-bit identifier and 8 data bytes, protected in the style of AUTOSAR
E2E. Byte 0 is the CRC-8H2F (polynomial 0x2F, init 0xFF, final xor 0xFF) over
the frame's 16-bit data ID (low byte first; the DBC attribute ``E2EDataID``)
followed by bytes 1..7; bits 8..11 are a 4-bit alive counter that the sender
increments for every frame of that identifier.

:class:`Protocol` encodes physical values into protected :class:`can.Message`
objects and checks and decodes received ones, with the same rules as the
firmware: values are rounded to the nearest raw value (halves away from zero),
never wrapped. A value beyond its signal's range (or NaN) is refused with
:class:`~mstc.errors.SignalRangeError` rather than saturated as comm.c does, so that the
plant never hands the firmware something other than what it simulates
without saying so; ``saturate=True`` applies the firmware's rule instead (the
tests that compare the two encoders use it). A received frame with an
unknown identifier, a wrong length, a bad CRC or a repeated or too far
advanced counter is counted and dropped (:class:`~mstc.errors.FrameDropped`).

Signals are named without their message prefix: ``x`` for ``ODOM_XY_x``.
"""

from __future__ import annotations

import enum
import functools
import math
import struct
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import can
from cantools.database.can import Message, Signal

from mstc.can.dbc import DBC_PATH as DBC_PATH
from mstc.can.dbc import E2E_SIGNALS, Tables, e2e_data_ids, short_name, tables
from mstc.can.dbc import load_database as load_database
from mstc.errors import FrameDropped, SignalRangeError
from mstc.model import SignalRange, WireLimits

DLC = 8
"""Length of every frame [bytes]."""
COUNTER_MODULO = 16
"""The alive counter is 4 bits."""
MAX_COUNTER_JUMP = 3
"""Largest accepted counter increment (COMM_MAX_COUNTER_JUMP): up to two lost frames."""
DROP_COUNT_MAX = 4095
"""Drop counters saturate here, as in the firmware's STATUS_COUNTERS."""

Value = float | int | str
"""A signal value: a number in the signal's unit, or the name of one of its choices."""


def _crc8h2f_byte(crc: int) -> int:
    """Eight steps of the CRC-8H2F shift register (polynomial 0x2F, MSB first)."""
    for _ in range(8):
        crc = ((crc << 1) ^ 0x2F) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


# One lookup per byte instead of eight shifts: the real-time plant computes a
# CRC for every frame it sends and receives, 50 times a second.
_CRC8H2F_TABLE = tuple(_crc8h2f_byte(i) for i in range(256))


def crc8h2f(data: bytes | bytearray | memoryview, crc: int = 0xFF) -> int:
    """CRC-8H2F (AUTOSAR ``Crc_CalculateCRC8H2F``): check value 0xDF for b"123456789".

    :param data: the bytes.
    :param crc: start value (0xFF, the init of CRC-8H2F).
    :returns: the CRC, final xor applied.
    """
    table = _CRC8H2F_TABLE
    for byte in data:
        crc = table[crc ^ byte]
    return crc ^ 0xFF


def e2e_crc(data_id: int, payload: bytes | bytearray) -> int:
    """The CRC of a frame: over its data ID (low byte first) and payload bytes 1..7."""
    return _frame_crc(_crc_start(data_id), payload)


def _crc_start(data_id: int) -> int:
    """The CRC-8H2F register after a frame's data ID (low byte first), before
    its payload: the same for every frame of an identifier."""
    table = _CRC8H2F_TABLE
    return table[table[0xFF ^ (data_id & 0xFF)] ^ (data_id >> 8)]


def _frame_crc(start: int, payload: bytes | bytearray) -> int:
    """The CRC of a frame from :func:`_crc_start` over payload bytes 1..7."""
    table = _CRC8H2F_TABLE
    crc = start
    for byte in payload[1:DLC]:
        crc = table[crc ^ byte]
    return crc ^ 0xFF


NODE_STRIDE = 0x100
"""What one step of node id adds to every identifier (FW_VERSION_node)."""
MAX_NODE_ID = 6
"""The largest node id: 0x191 + 6 x 0x100 is still an 11-bit identifier."""


class DropReason(enum.Enum):
    """Why a received frame was dropped; the values are the firmware's counter names."""

    UNKNOWN = "unknown"
    """Identifier not in the DBC, or not received by this node."""
    LENGTH = "len"
    """DLC other than 8."""
    CRC = "crc"
    """CRC mismatch."""
    SEQUENCE = "seq"
    """Alive counter repeated, or advanced by more than MAX_COUNTER_JUMP."""


@dataclass(frozen=True)
class Frame:
    """A received frame that passed every check."""

    name: str
    """Message name in the DBC, e.g. ``"WHEEL_CMD"``."""
    frame_id: int
    counter: int
    """Its alive counter."""
    signals: dict[str, float | int]
    """Physical values by short name (without CRC and counter); choices as numbers."""
    timestamp: float = 0.0
    """The received message's time stamp [s]."""


@dataclass
class _Counters:
    tx: dict[int, int] = field(default_factory=dict)
    """The next alive counter to send, by identifier."""
    rx: dict[int, int] = field(default_factory=dict)
    """The last alive counter received with a good CRC, by identifier."""


def _field_range(signal: Signal) -> tuple[int, int]:
    """Raw values the signal's bits can hold."""
    return _bits_range(signal.is_signed, signal.length)


def _bits_range(is_signed: bool, length: int) -> tuple[int, int]:
    if is_signed:
        return -(1 << (length - 1)), (1 << (length - 1)) - 1
    return 0, (1 << length) - 1


def raw_range(signal: Signal) -> tuple[int, int]:
    """Raw range of an integer signal: its DBC [min|max] within what its bits hold."""
    s = signal
    return _raw_range(s.is_signed, s.length, s.minimum, s.maximum, s.offset, s.scale)


@functools.cache
def _raw_range(
    is_signed: bool,
    length: int,
    minimum: float | None,
    maximum: float | None,
    offset: float,
    scale: float,
) -> tuple[int, int]:
    # Cached by value: every frame the plant encodes asks again.
    lo, hi = _bits_range(is_signed, length)
    if minimum is not None:
        lo = max(lo, math.ceil(round((minimum - offset) / scale, 6)))
    if maximum is not None:
        hi = min(hi, math.floor(round((maximum - offset) / scale, 6)))
    return lo, hi


def physical_range(signal: Signal) -> tuple[float, float]:
    """The values @p signal carries [its unit]: the DBC's [min|max] within what
    its bits hold (IEEE float signals: the DBC's [min|max])."""
    if signal.is_float:
        # The DBC gives every float signal its range (PARAM_SET/VALUE value).
        assert signal.minimum is not None and signal.maximum is not None
        return float(signal.minimum), float(signal.maximum)
    lo, hi = raw_range(signal)
    return lo * signal.scale + signal.offset, hi * signal.scale + signal.offset


@functools.cache
def wire_limits(path: Path = DBC_PATH) -> WireLimits:
    """The ranges of the signals a scenario's values travel in, from the DBC at
    @p path (read once): what the scenario loader is handed
    (:func:`mstc.plant.scenario.load_scenario`)."""
    db = load_database(path)

    def signal(message: str, name: str) -> SignalRange:
        s = db.get_message_by_name(message).get_signal_by_name(f"{message}_{name}")
        lo, hi = physical_range(s)
        return SignalRange(f"{message}.{name}", lo, hi, s.unit or "", float(s.scale))

    return WireLimits(
        robot=(signal("ODOM_XY", "x"), signal("ODOM_XY", "y")),
        reference=(signal("REF_XY", "x"), signal("REF_XY", "y")),
        v=signal("REF_MOTION", "v"),
        w=signal("REF_MOTION", "w"),
        obstacle=(signal("OBSTACLE", "x"), signal("OBSTACLE", "y")),
        radius=signal("OBSTACLE", "radius"),
        velocity=(signal("OBSTACLE_VEL", "vx"), signal("OBSTACLE_VEL", "vy")),
        ids=signal("OBSTACLE", "id"),
    )


def _round_half_away(x: float) -> int:
    return int(math.copysign(math.floor(abs(x) + 0.5), x))


def to_raw(signal: Signal, value: Value, *, saturate: bool = False, frame: str = "") -> float | int:
    """The raw value of @p value, rounded to nearest (halves away from zero).

    :param saturate: the firmware's rule (comm.c): saturate to the signal's
        range, NaN giving 0; IEEE float signals pass unchanged. Without it,
        a value that does not round into the range, or NaN, raises.
    :param frame: the signal's message name, for the error.
    :raises SignalRangeError: without @p saturate, the value is not carried.
    """
    if isinstance(value, str):
        value = _choice_value(signal, value)
    if signal.is_float:
        lo_f, hi_f = physical_range(signal)
        if saturate or lo_f <= value <= hi_f:
            return float(value)
        raise _range_error(signal, frame, value, (lo_f, hi_f), signal.unit or "")
    x = (value - signal.offset) / signal.scale
    lo, hi = raw_range(signal)
    if not saturate:
        # Compared before rounding, so that an infinite x is refused, not floored.
        if not (lo - 1 <= x <= hi + 1 and lo <= _round_half_away(x) <= hi):
            raise _range_error(signal, frame, value, physical_range(signal), signal.unit or "")
        return _round_half_away(x)
    if math.isnan(x):
        return min(max(0, lo), hi)
    if x <= lo:
        return lo
    if x >= hi:
        return hi
    return _round_half_away(x)


def _range_error(
    signal: Signal, frame: str, value: float, limits: tuple[float, float], unit: str
) -> SignalRangeError:
    return SignalRangeError(
        frame or "?", signal.name.removeprefix(f"{frame}_"), float(value), limits, unit
    )


def _choice_value(signal: Signal, name: str) -> int:
    for number, choice in (signal.choices or {}).items():
        if str(choice) == name:
            return int(number)
    raise ValueError(f"{signal.name} has no choice {name!r}")


@dataclass(frozen=True)
class _Field:
    """Where one signal of a little-endian frame sits, and how it scales."""

    short: str
    signal: Signal
    start: int
    length: int
    mask: int
    is_signed: bool
    is_float: bool
    offset: float
    scale: float
    lo: float
    """Raw range of an integer signal (:func:`raw_range`); the physical range
    of an IEEE float one (:func:`physical_range`)."""
    hi: float
    cscale: float
    """Scale and offset of cantools' conversion of the signal (ints for an
    integer one, so that its values stay ints as cantools' do)."""
    coffset: float


class _Codec:
    """The signals of one message, packed into and read from the frame's 8
    bytes as one little-endian integer: cantools' layout (every mstc signal
    is little-endian, ``@1``), without its per-call generality. Proven equal
    to cantools' encoding and decoding on random values of every message
    (tests/python/test_protocol_codec.py). The real-time plant encodes and
    decodes some ten frames every 20 ms; in the emulated VM cantools' path
    alone took most of a period."""

    def __init__(self, message: Message) -> None:
        self.message = message
        self.name = message.name
        fields = []
        for s in message.signals:
            if s.byte_order != "little_endian" or (s.is_float and s.length != 32):
                raise ValueError(f"{s.name}: mstc signals are little-endian, floats single")
            lo, hi = physical_range(s) if s.is_float else raw_range(s)
            fields.append(
                _Field(
                    short_name(message, s.name),
                    s,
                    s.start,
                    s.length,
                    (1 << s.length) - 1,
                    s.is_signed,
                    s.is_float,
                    s.offset,
                    s.scale,
                    lo,
                    hi,
                    s.conversion.scale,
                    s.conversion.offset,
                )
            )
        self.fields = tuple(f for f in fields if f.short not in E2E_SIGNALS)
        self.wanted = frozenset(f.short for f in self.fields)

    def pack(
        self, values: Mapping[str, Value], *, raw: bool = False, saturate: bool = False
    ) -> bytearray:
        """The frame's bytes (CRC and counter 0) of @p values (see
        :meth:`Protocol.encode` for @p raw and @p saturate), each rounded to
        nearest as :func:`to_raw` does.

        :raises SignalRangeError: a value its signal cannot carry.
        """
        acc = 0
        for f in self.fields:
            value = values[f.short]
            r: float | int | None = None
            if raw:
                r = self._raw(f, value)
            elif not (saturate or isinstance(value, str)):
                # The common case without to_raw's lookups; the same rule.
                if f.is_float:
                    r = value if f.lo <= value <= f.hi else None
                else:
                    x = (value - f.offset) / f.scale
                    if f.lo - 1 <= x <= f.hi + 1 and f.lo <= (k := _round_half_away(x)) <= f.hi:
                        r = k
            if r is None:  # to_raw applies the rule, and names a value out of range
                r = to_raw(f.signal, value, saturate=saturate, frame=self.name)
            bits = int.from_bytes(_F32.pack(r), "little") if f.is_float else int(r)
            acc |= (bits & f.mask) << f.start
        return bytearray(acc.to_bytes(DLC, "little"))

    def _raw(self, f: _Field, value: Value) -> float | int:
        """A raw value of :meth:`pack`, checked only against what its bits hold."""
        if isinstance(value, str):
            raise TypeError(f"{self.name}.{f.short}: a raw value is a number: {value!r}")
        if f.is_float:
            return value
        field = _field_range(f.signal)
        if not field[0] <= value <= field[1]:
            raise _range_error(f.signal, self.name, float(value), field, f"raw, {f.length} bits")
        return int(value)

    def unpack(self, data: bytes) -> dict[str, float | int]:
        """The physical values of a frame's bytes, by short name (CRC and
        counter left out), as cantools' decode with scaling and without
        choices gives them."""
        v = int.from_bytes(data, "little")
        out: dict[str, float | int] = {}
        for f in self.fields:
            raw = (v >> f.start) & f.mask
            if f.is_float:
                out[f.short] = _F32.unpack(raw.to_bytes(4, "little"))[0]
                continue
            if f.is_signed and raw >> (f.length - 1):
                raw -= 1 << f.length
            out[f.short] = raw * f.cscale + f.coffset  # cantools' raw_to_scaled
        return out


_F32 = struct.Struct("<f")


class Protocol:
    """One node's side of the protocol: E2E counters, encoding and checked decoding.

    :param node: the node this side plays (``"PLANT"``, ``"FW"`` or ``"TOOL"``);
        frames it does not receive are dropped as unknown, as the firmware
        drops the frames it only sends. ``None`` accepts every frame of the
        DBC (log decoders, monitors).
    :param dbc_path: the DBC; the package's by default.
    :param node_id: the board's node id, 0 .. :data:`MAX_NODE_ID`: frames are
        sent and received under the DBC's identifiers plus
        :data:`NODE_STRIDE` times it (FW_VERSION_node, docs/protocol.md);
        another board's frames are dropped uncounted (``foreign``).
    """

    def __init__(
        self, node: str | None = None, dbc_path: Path = DBC_PATH, node_id: int = 0
    ) -> None:
        self.db = load_database(dbc_path)
        if node is not None and node not in {n.name for n in self.db.nodes}:
            raise ValueError(f"no node {node!r} in {dbc_path.name}")
        if not 0 <= node_id <= MAX_NODE_ID:
            raise ValueError(f"node id {node_id}: 0 to {MAX_NODE_ID}")
        self.node = node
        self.node_id = node_id
        self.offset = node_id * NODE_STRIDE
        """What the node id adds to every identifier."""
        self.foreign = 0
        """Frames of another board's identifiers, dropped uncounted."""
        self._data_ids = e2e_data_ids(self.db)
        self._crc_starts = {i: _crc_start(d) for i, d in self._data_ids.items()}
        self._codecs = {m.frame_id: _Codec(m) for m in self.db.messages}
        self._codec_by_name = {c.name: c for c in self._codecs.values()}
        self._counters = _Counters()
        self.drops: dict[DropReason, int] = dict.fromkeys(DropReason, 0)
        """Received frames dropped, by reason (saturating at DROP_COUNT_MAX)."""

    @property
    def tables(self) -> Tables:
        """The DBC's value tables (parameter indexes, modes, ...; :mod:`mstc.can.dbc`).

        :raises DbcError: the DBC lacks an entry the Python side names.
        """
        return tables(self.db)

    def reset(self) -> None:
        """Forget counters and drop counts, as comm_init() does."""
        self._counters = _Counters()
        self.drops = dict.fromkeys(DropReason, 0)

    @property
    def tx_counters(self) -> dict[int, int]:
        """The next alive counter to send, by the DBC's identifier: what a
        tool that runs again later continues from (``mstc board``)."""
        return dict(self._counters.tx)

    @tx_counters.setter
    def tx_counters(self, counters: Mapping[int, int]) -> None:
        self._counters.tx = {int(k): int(v) % COUNTER_MODULO for k, v in counters.items()}

    def data_id(self, frame_id: int) -> int:
        """The E2E data ID of a frame (its ``E2EDataID`` attribute)."""
        return self._data_ids[frame_id]

    def message(self, name_or_id: str | int) -> Message:
        """The DBC message of a name or identifier."""
        if isinstance(name_or_id, str):
            return self.db.get_message_by_name(name_or_id)
        return self.db.get_message_by_frame_id(name_or_id)

    # ------------------------------------------------------------- sending

    def encode(
        self,
        name: str,
        signals: Mapping[str, Value] | None = None,
        *,
        raw: bool = False,
        saturate: bool = False,
        timestamp: float = 0.0,
        **kwargs: Value,
    ) -> can.Message:
        """A protected frame: signals scaled and checked against their range,
        the next alive counter of its identifier, then the CRC.

        :param name: message name, e.g. ``"ODOM_XY"``.
        :param signals: values by short name; every signal but CRC and counter
            is required. Keyword arguments add to them.
        :param raw: the values are raw integers, checked only against what the
            signal's bits hold, so that a test can send values outside the
            DBC range (an obstacle id 0, an unknown parameter index).
        :param saturate: saturate values to their signal's range as the
            firmware does (comm.c) instead of refusing them.
        :param timestamp: the message's time stamp [s].
        :raises KeyError: a signal is missing or unknown.
        :raises SignalRangeError: a value its signal cannot carry (without
            @p saturate): nothing is sent, and the alive counter is unchanged.
        """
        values = {**(signals or {}), **kwargs}
        codec = self._codec_by_name.get(name)
        if codec is None:
            raise KeyError(f"no message {name!r} in the DBC")
        message = codec.message
        if values.keys() != codec.wanted:
            raise KeyError(
                f"{message.name}: missing {sorted(codec.wanted - set(values))}, "
                f"unknown {sorted(set(values) - codec.wanted)}"
            )
        data = codec.pack(values, raw=raw, saturate=saturate)
        self.protect(message.frame_id, data)
        return can.Message(
            arbitration_id=message.frame_id + self.offset,
            is_extended_id=False,
            dlc=DLC,
            data=data,
            timestamp=timestamp,
        )

    def protect(self, frame_id: int, data: bytearray) -> None:
        """Write the next alive counter of @p frame_id into bits 8..11 of
        @p data, then the CRC into byte 0."""
        counter = self._counters.tx.get(frame_id, 0)
        self._counters.tx[frame_id] = (counter + 1) % COUNTER_MODULO
        data[1] = (data[1] & 0xF0) | counter
        data[0] = _frame_crc(self._crc_starts[frame_id], data)

    # ----------------------------------------------------------- receiving

    def _drop(self, reason: DropReason, frame_id: int, detail: str) -> FrameDropped:
        self.drops[reason] = min(self.drops[reason] + 1, DROP_COUNT_MAX)
        return FrameDropped(reason, frame_id, detail)

    def check(self, msg: can.Message) -> int:
        """E2E checks of a received frame, in the firmware's order: identifier
        known (and received by this node), DLC 8, CRC, alive counter.

        The counter follows every frame with a good CRC, accepted or not; the
        first frame of an identifier is accepted whatever its counter.

        :returns: the frame's alive counter.
        :raises FrameDropped: a check failed; the drop is counted.
        """
        frame_id = msg.arbitration_id - self.offset
        codec = self._codecs.get(frame_id) if not msg.is_extended_id else None
        message = codec.message if codec is not None else None
        if message is None:
            other = self.node_of(msg)
            if other is not None:  # as the firmware: another board's, not counted
                self.foreign += 1
                raise FrameDropped(DropReason.UNKNOWN, msg.arbitration_id, f"node {other}'s")
            raise self._drop(DropReason.UNKNOWN, msg.arbitration_id, "not in the DBC")
        if self.node is not None and self.node not in message.receivers:
            raise self._drop(DropReason.UNKNOWN, frame_id, f"{self.node} does not receive it")
        if msg.dlc != DLC or len(msg.data) != DLC:
            raise self._drop(DropReason.LENGTH, frame_id, f"DLC {msg.dlc}")
        data = bytes(msg.data)
        want = _frame_crc(self._crc_starts[frame_id], data)
        if data[0] != want:
            raise self._drop(DropReason.CRC, frame_id, f"CRC 0x{data[0]:02X}, want 0x{want:02X}")
        counter = data[1] & 0x0F
        rx = self._counters.rx
        last = rx.get(frame_id)
        rx[frame_id] = counter
        if last is not None:
            delta = (counter - last) % COUNTER_MODULO
            if delta == 0:
                raise self._drop(DropReason.SEQUENCE, frame_id, f"counter {counter} repeated")
            if delta > MAX_COUNTER_JUMP:
                raise self._drop(
                    DropReason.SEQUENCE, frame_id, f"counter {last} -> {counter}: jump {delta}"
                )
        return counter

    def decode(self, msg: can.Message) -> Frame:
        """Check (see :meth:`check`) and decode a received frame.

        :raises FrameDropped: a check failed; the drop is counted.
        """
        counter = self.check(msg)
        codec = self._codecs[msg.arbitration_id - self.offset]
        signals = codec.unpack(bytes(msg.data))
        return Frame(codec.name, codec.message.frame_id, counter, signals, msg.timestamp)

    def node_of(self, msg: can.Message) -> int | None:
        """The node id whose identifiers hold @p msg's (the DBC's plus
        :data:`NODE_STRIDE` times it), None for none."""
        if msg.is_extended_id:
            return None
        node, base = divmod(msg.arbitration_id - NODE_STRIDE, NODE_STRIDE)
        if 0 <= node <= MAX_NODE_ID and base + NODE_STRIDE in self._codecs:
            return node
        return None
