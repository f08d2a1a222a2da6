# SPDX-License-Identifier: MIT
"""The plant's frame encoder (mstc.can.protocol) never clips silently (issue 13,
case 3 and case 4): a value beyond its signal's range, an obstacle id 49, a
NaN, raise an error naming the frame, the signal, the value and the range; the
firmware's saturating rule (comm.c) stays available on request, for the tests
that compare the two encoders.

Expected ranges are read by hand from firmware/comm/mstc.dbc.
"""

from __future__ import annotations

import math

import cantools
import pytest

from logfiles import DBC
from mstc.can import protocol
from mstc.can.protocol import Protocol
from mstc.errors import MstcError


@pytest.mark.parametrize(
    ("name", "values", "words"),
    [
        # Case 3: obstacle 49 would go out as id 48 and overwrite obstacle 48.
        ("OBSTACLE", {"id": 49, "x": 1.0, "y": 2.0, "radius": 0.1}, ("OBSTACLE", "id", "49", "48")),
        ("OBSTACLE", {"id": 0, "x": 1.0, "y": 2.0, "radius": 0.1}, ("OBSTACLE", "id", "0", "1")),
        # Case 4: a robot at x = 200 m, a reference at 20 m/s, an obstacle of 3 m.
        ("ODOM_XY", {"x": 200.0, "y": 0.0}, ("ODOM_XY", "x", "200", "-128")),
        ("REF_XY", {"x": 0.0, "y": -128.5}, ("REF_XY", "y", "-128.5", "-128")),
        ("REF_MOTION", {"theta": 0.0, "v": 20.0, "w": 0.0}, ("REF_MOTION", "v", "20", "16")),
        ("REF_MOTION", {"theta": 0.0, "v": 0.0, "w": 1e308}, ("REF_MOTION", "w", "1e+308", "16")),
        (
            "OBSTACLE",
            {"id": 1, "x": 1.0, "y": 2.0, "radius": 3.0},
            ("OBSTACLE", "radius", "3", "2.55"),
        ),
        ("OBSTACLE", {"id": 1, "x": 1.0, "y": 2.0, "radius": 0.001}, ("radius", "0.001", "0.01")),
        ("ODOM_THETA", {"theta": math.nan}, ("ODOM_THETA", "theta", "nan")),
        ("PARAM_SET", {"index": 2, "value": 1e39}, ("PARAM_SET", "value", "1e+39")),
        ("PARAM_SET", {"index": 256, "value": 1.0}, ("PARAM_SET", "index", "256", "255")),
        ("STEP", {"step": 65536, "time": 0.0}, ("STEP", "step", "65536", "65535")),
    ],
)
def test_a_value_beyond_its_signal_range_raises_naming_frame_signal_value_and_range(
    name: str, values: dict[str, float], words: tuple[str, ...]
) -> None:
    proto = Protocol("PLANT" if name != "PARAM_SET" else "TOOL")
    with pytest.raises(protocol.SignalRangeError) as info:
        proto.encode(name, values)
    message = str(info.value)
    assert isinstance(info.value, MstcError)
    assert "\n" not in message
    for word in words:
        assert word in message, (word, message)


def test_raw_values_beyond_the_bits_raise_too() -> None:
    proto = Protocol()
    # Within the bits, outside the DBC range: allowed raw, so that a test can
    # send what a faulty node would (an obstacle id 0).
    # Within the 6 bits, outside the DBC range (1..48): id 63.
    msg = proto.encode("OBSTACLE", id=0, x=0, y=0, radius=0, raw=True)
    assert msg.data[1] >> 4 == 0 and msg.data[2] & 3 == 0
    msg = proto.encode("OBSTACLE", id=63, x=0, y=0, radius=0, raw=True)
    assert msg.data[1] >> 4 == 15 and msg.data[2] & 3 == 3
    with pytest.raises(protocol.SignalRangeError, match=r"OBSTACLE.*id.*64"):
        proto.encode("OBSTACLE", id=64, x=0, y=0, radius=1, raw=True)
    with pytest.raises(protocol.SignalRangeError, match=r"STEP.*time"):
        proto.encode("STEP", step=0, time=1 << 32, raw=True)


def test_the_edges_of_every_range_encode_exactly() -> None:
    db = cantools.database.load_file(DBC)
    proto = Protocol()
    for message in db.messages:
        prefix = f"{message.name}_"
        signals = [s for s in message.signals if s.name not in (f"{prefix}CRC", f"{prefix}Counter")]
        for edge in ("minimum", "maximum"):
            values = {s.name.removeprefix(prefix): getattr(s, edge) for s in signals}
            msg = proto.encode(message.name, values)
            decoded = message.decode(bytes(msg.data), decode_choices=False)
            for s in signals:
                assert decoded[s.name] == pytest.approx(getattr(s, edge), rel=1e-7), s.name


def test_a_value_that_rounds_to_the_edge_is_not_clipping() -> None:
    # 127.99999 m is 8388607.3 raw: it rounds to the largest raw value, as
    # any value between two raw values rounds to the nearer one.
    proto = Protocol()
    msg = proto.encode("ODOM_XY", x=127.99999, y=-127.999999)
    decoded = proto.db.get_message_by_name("ODOM_XY").decode(bytes(msg.data))
    assert decoded["ODOM_XY_x"] == 127.9999847412109375
    assert decoded["ODOM_XY_y"] == -128.0


def test_the_firmware_rule_saturates_on_request() -> None:
    proto = Protocol()
    msg = proto.encode("OBSTACLE", id=49, x=200.0, y=-200.0, radius=3.0, saturate=True)
    decoded = proto.db.get_message_by_name("OBSTACLE").decode(bytes(msg.data))
    assert decoded["OBSTACLE_id"] == 48
    assert decoded["OBSTACLE_x"] == 127.99951171875  # 2^18 - 1 steps of 2^-11 m
    assert decoded["OBSTACLE_y"] == -128.0
    assert decoded["OBSTACLE_radius"] == pytest.approx(2.55, abs=1e-12)  # 255 cm
