# SPDX-License-Identifier: MIT
"""protocol.py's own packing and unpacking (mstc.can.protocol._Codec) against
cantools, the independent reference: on seeded random values of every message
of the DBC, Protocol.encode gives the bytes cantools' encode gives for the
same raw values (rounded by to_raw, then the alive counter and the CRC), and
Protocol.decode gives the values, and their types, of cantools' decode.
Values out of range are refused as before, and leave the counter alone.
"""

from __future__ import annotations

import math
import random

import can
import pytest
from cantools.database.can import Message

from mstc.can.dbc import E2E_SIGNALS, short_name
from mstc.can.protocol import DLC, Protocol, e2e_crc, physical_range, to_raw
from mstc.errors import SignalRangeError

SEED = 15
N_RANDOM = 300
DB = Protocol().db
MESSAGES = list(DB.messages)


def random_values(message: Message, rng: random.Random) -> dict[str, float | int | str]:
    """Physical values within range: uniform, at an edge, on a raw step, a
    half step (rounding), or a value-table name."""
    out: dict[str, float | int | str] = {}
    for s in message.signals:
        short = short_name(message, s.name)
        if short in E2E_SIGNALS:
            continue
        lo, hi = physical_range(s)
        pick = rng.randrange(5)
        if s.choices and pick == 4:
            out[short] = str(rng.choice(list(s.choices.values())))
        elif s.is_float:
            out[short] = rng.choice([lo, hi, 0.0, rng.uniform(-1e6, 1e6), rng.uniform(lo, hi)])
        elif pick == 0:
            out[short] = rng.choice([lo, hi])
        elif pick == 1:
            out[short] = (
                rng.randint(round((lo - s.offset) / s.scale), round((hi - s.offset) / s.scale))
                * s.scale
                + s.offset
            )
        elif pick == 2:
            k = rng.randint(round((lo - s.offset) / s.scale), round((hi - s.offset) / s.scale) - 1)
            out[short] = (k + 0.5) * s.scale + s.offset
        else:
            out[short] = rng.uniform(lo, hi)
    return out


def cantools_frame(message: Message, values: dict[str, float | int | str], counter: int) -> bytes:
    raw: dict[str, float | int] = {f"{message.name}_{e}": 0 for e in E2E_SIGNALS}
    for short, value in values.items():
        signal = message.get_signal_by_name(f"{message.name}_{short}")
        raw[signal.name] = to_raw(signal, value, frame=message.name)
    data = bytearray(message.encode(raw, scaling=False, strict=False))
    data[1] = (data[1] & 0xF0) | counter
    data_id = int(message.dbc.attributes["E2EDataID"].value)
    data[0] = e2e_crc(data_id, data)
    return bytes(data)


@pytest.mark.parametrize("message", MESSAGES, ids=lambda m: m.name)
def test_encode_is_cantools_encode(message: Message) -> None:
    rng = random.Random(f"{SEED}-{message.name}")
    proto = Protocol()
    for i in range(N_RANDOM):
        values = random_values(message, rng)
        got = proto.encode(message.name, values)
        assert bytes(got.data) == cantools_frame(message, values, i % 16), values
        assert got.arbitration_id == message.frame_id and got.dlc == DLC


@pytest.mark.parametrize("message", MESSAGES, ids=lambda m: m.name)
def test_raw_encode_is_cantools_encode(message: Message) -> None:
    """raw=True: any value the signal's bits hold, even outside the DBC range."""
    rng = random.Random(f"{SEED}-raw-{message.name}")
    proto = Protocol()
    data_id = int(message.dbc.attributes["E2EDataID"].value)
    for i in range(N_RANDOM):
        values: dict[str, float | int] = {}
        for s in message.signals:
            short = short_name(message, s.name)
            if short in E2E_SIGNALS:
                continue
            if s.is_float:
                values[short] = rng.uniform(-1e30, 1e30)
            else:
                lo = -(1 << (s.length - 1)) if s.is_signed else 0
                values[short] = rng.randint(lo, lo + (1 << s.length) - 1)
        full = {f"{message.name}_{k}": v for k, v in values.items()}
        full.update({f"{message.name}_{e}": 0 for e in E2E_SIGNALS})
        want = bytearray(message.encode(full, scaling=False, strict=False))
        want[1] = (want[1] & 0xF0) | (i % 16)
        want[0] = e2e_crc(data_id, want)
        got = proto.encode(message.name, values, raw=True)
        assert bytes(got.data) == bytes(want), values


@pytest.mark.parametrize("message", MESSAGES, ids=lambda m: m.name)
def test_decode_is_cantools_decode(message: Message) -> None:
    rng = random.Random(f"{SEED}-decode-{message.name}")
    proto = Protocol()
    data_id = int(message.dbc.attributes["E2EDataID"].value)
    for i in range(N_RANDOM):
        data = bytearray(rng.randbytes(DLC))
        data[1] = (data[1] & 0xF0) | (i % 16)
        data[0] = e2e_crc(data_id, data)
        frame = proto.decode(
            can.Message(arbitration_id=message.frame_id, data=data, dlc=DLC, is_extended_id=False)
        )
        want = {
            short_name(message, k): v
            for k, v in message.decode(bytes(data), decode_choices=False, scaling=True).items()
            if short_name(message, k) not in E2E_SIGNALS
        }
        assert frame.name == message.name and frame.counter == i % 16
        assert frame.signals.keys() == want.keys()
        for k, v in want.items():
            g = frame.signals[k]
            assert type(g) is type(v), (k, g, v)
            assert g == v or (math.isnan(g) and math.isnan(v)), (k, g, v)


@pytest.mark.parametrize("message", MESSAGES, ids=lambda m: m.name)
def test_a_value_out_of_range_is_refused_and_keeps_the_counter(message: Message) -> None:
    rng = random.Random(f"{SEED}-range-{message.name}")
    proto = Protocol()
    for signal in message.signals:
        short = short_name(message, signal.name)
        if short in E2E_SIGNALS:
            continue
        lo, hi = physical_range(signal)
        step = 0.0 if signal.is_float else signal.scale
        for bad in (hi + step, lo - step, math.inf, -math.inf, math.nan, 1e300):
            if signal.is_float and bad in (hi, lo):
                continue
            values = random_values(message, rng)
            values[short] = bad
            with pytest.raises(SignalRangeError):
                to_raw(signal, bad, frame=message.name)
            with pytest.raises(SignalRangeError):
                proto.encode(message.name, values)
    # Nothing was sent: the first frame still carries counter 0.
    good = random_values(message, rng)
    assert proto.encode(message.name, good).data[1] & 0x0F == 0
