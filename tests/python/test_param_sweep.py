# SPDX-License-Identifier: MIT
"""10 000 random PARAM_SET sequences, each followed by an odometry cut, in each
numeric mode (issue 13, acceptance): never a wheel command above zero 1 s
after the cut, never a parameter set in force that the check refuses.

Each trial restarts the firmware (the in-process library, through its frame
ABI: mstc_sil_fw_init / _send / _recv, the frame path a board has), pre-rolls
the inputs, then mixes control steps with PARAM_SETs of random index (every
parameter, the arm command, unknown ones) and random value (in range, at and
across the ends of the ranges and of the relations, tiny, huge, negative,
non-finite), armed or not; arms or not; drives three steps; then cuts the
odometry at a random phase and keeps sending the reference and STEP, with
more random PARAM_SETs during the halt. "The cut" is the last odometry frame
sent (of the two frames, the one cut first): every WHEEL_CMD of a step 1 s
or more after it must be exactly zero. The parameters in force are then read
back (PARAM_GET) and checked with mstc.limits as the firmware holds them.

Frames are packed here from the DBC's layout (bit positions, scales) and
protected with a CRC-8H2F table built from its polynomial, independently of
comm.c and of mstc.can.protocol (which checks the packing once, first); the
fixed frames of a trial (inputs, STEP) are built once.
"""

from __future__ import annotations

import ctypes
import math
import os
import random
import struct
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from mstc.can import secoc
from mstc.can.protocol import Protocol
from mstc.limits import Held, load_table, violation

TRIALS = int(os.environ.get("MSTC_SWEEP_TRIALS", "10000"))
DT_US = 20_000
STOP_S = 1.0
"""The bound: wheels at zero this long after the last odometry frame [s]."""
AFTER_CUT = round(STOP_S * 1e6 / DT_US) + 2
"""Steps run after the cut: to the bound and two beyond."""
ARM = 128
TABLE = load_table()
HELD = [p for p in TABLE.params if p.held]
BY_INDEX = {p.index: p for p in TABLE.params}
"""The table's rows by PARAM_SET index (an index may be left out: reserved)."""
RESULTS = {0: "ok", 1: "unknown_index", 2: "out_of_range", 3: "rejected", 5: "armed"}
KEY = secoc.load_key()  # the published test key (conftest.py)
REPORT: list[str] = []

ODOM_XY, ODOM_THETA, REF_XY, REF_MOTION, STEP = 0x100, 0x101, 0x102, 0x103, 0x104
PARAM_SET, PARAM_GET, PARAM_AUTH = 0x120, 0x121, 0x122
WHEEL_CMD, STATUS, PARAM_VALUE = 0x180, 0x181, 0x190


# ------------------------------------------------------------------ frames


def _crc_table() -> list[int]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x2F) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table.append(crc)
    return table


CRC = _crc_table()


def seal(frame_id: int, payload: int, counter: int) -> bytes:
    """8 bytes: @p payload (bits 12..63 as an integer, little-endian bit
    numbering), the alive counter in bits 8..11 and the CRC-8H2F over the data
    ID (0x1000 + id, low byte first) and bytes 1..7 in byte 0."""
    word = (payload & ~0xFFF) | ((counter & 0xF) << 8)
    data = bytearray(word.to_bytes(8, "little"))
    data_id = 0x1000 + frame_id
    crc = 0xFF
    for b in (data_id & 0xFF, data_id >> 8, *data[1:]):
        crc = CRC[crc ^ b]
    data[0] = crc ^ 0xFF
    return bytes(data)


def _signed(value: float, scale: float, bits: int, start: int) -> int:
    raw = round(value / scale)
    assert -(1 << (bits - 1)) <= raw < 1 << (bits - 1)
    return (raw & ((1 << bits) - 1)) << start


def odom_xy(x: float, y: float) -> int:
    return _signed(x, 2**-16, 24, 16) | _signed(y, 2**-16, 24, 40)


def odom_theta(theta: float) -> int:
    return _signed(theta, 2**-16, 20, 16)


def ref_motion(theta: float, v: float, w: float) -> int:
    return _signed(theta, 2**-15, 18, 12) | _signed(v, 2**-12, 17, 30) | _signed(w, 2**-12, 17, 47)


def step_payload(k: int) -> int:
    return (k << 16) | ((k * DT_US) << 32)


def param_set(index: int, value: float) -> int:
    return (index << 16) | (int.from_bytes(struct.pack("<f", value), "little") << 24)


SESSION = 0x5EC0A1D1
"""The session the sweep starts each firmware in (mstc_sil_fw_set_session)."""
AUTH_CHALLENGE = 0x187


def param_auth(pset: bytes, freshness: int) -> int:
    """PARAM_AUTH of the sealed PARAM_SET @p pset (docs/safety.md): the low 20
    bits of the freshness value at bit 12, the first 4 CMAC bytes at byte 4."""
    tag = secoc.cmac(KEY, secoc.mac_input(0x1000 + PARAM_SET, pset[2:8], SESSION, freshness))
    return ((freshness & 0xFFFFF) << 12) | (int.from_bytes(tag[:4], "little") << 32)


class _Frame(ctypes.Structure):
    """mstc_sil_frame_t (hal/sil/mstc_sil.h)."""

    _fields_ = [("id", ctypes.c_uint32), ("dlc", ctypes.c_uint8), ("data", ctypes.c_uint8 * 8)]


def c_frame(frame_id: int, data: bytes) -> _Frame:
    return _Frame(frame_id, 8, (ctypes.c_uint8 * 8)(*data))


def test_the_packing_here_is_the_protocols() -> None:
    """The hand packing above against mstc.can.protocol (cantools)."""
    proto = Protocol(node=None)
    cases = [
        (ODOM_XY, odom_xy(1.5, -2.25), proto.encode("ODOM_XY", x=1.5, y=-2.25)),
        (ODOM_THETA, odom_theta(-0.5), proto.encode("ODOM_THETA", theta=-0.5)),
        (REF_XY, odom_xy(3.0, 0.5), proto.encode("REF_XY", x=3.0, y=0.5)),
        (
            REF_MOTION,
            ref_motion(0.25, 0.5, -0.125),
            proto.encode("REF_MOTION", theta=0.25, v=0.5, w=-0.125),
        ),
        (STEP, step_payload(7), proto.encode("STEP", step=7, time=7 * DT_US, raw=True)),
        (PARAM_SET, param_set(12, 99.5), proto.encode("PARAM_SET", index=12, value=99.5)),
    ]
    for frame_id, payload, msg in cases:
        assert seal(frame_id, payload, 0) == bytes(msg.data), hex(frame_id)


# ------------------------------------------------------------------ the firmware


class Firmware:
    """One library's firmware instance, through its frame ABI."""

    def __init__(self, path: Path) -> None:
        self.lib = ctypes.CDLL(str(path.resolve()))
        for name in ("mstc_sil_fw_send", "mstc_sil_fw_recv"):
            getattr(self.lib, name).argtypes = [ctypes.POINTER(_Frame)]
            getattr(self.lib, name).restype = ctypes.c_int
        self.lib.mstc_sil_fw_init.argtypes = [ctypes.c_void_p]
        self.lib.mstc_sil_fw_set_key.argtypes = [ctypes.c_char_p, ctypes.c_size_t]
        self.lib.mstc_sil_fw_set_session.argtypes = [ctypes.c_uint32]
        self.fv = 0
        """The freshness value of the firmware's last AUTH_CHALLENGE: the
        challenge is this + 1."""
        self.lib.mstc_sil_numeric.restype = ctypes.c_char_p
        self.numeric = self.lib.mstc_sil_numeric().decode()
        self.rx = _Frame()
        self._send = self.lib.mstc_sil_fw_send
        self._recv = self.lib.mstc_sil_fw_recv

    def restart(self) -> None:
        """A fresh firmware with the test key, in session SESSION."""
        assert self.lib.mstc_sil_fw_init(None) == 0
        assert self.lib.mstc_sil_fw_set_key(KEY, len(KEY)) == 0
        assert self.lib.mstc_sil_fw_set_session(SESSION) == 0
        self.fv = 0

    def put(self, f: _Frame) -> None:
        """Send @p f, an input frame: the firmware answers none."""
        assert self._send(ctypes.byref(f)) == 0

    def send(self, f: _Frame) -> list[tuple[int, int]]:
        """Send @p f; the frames the firmware answered, as (id, 64-bit word)."""
        assert self._send(ctypes.byref(f)) == 0
        out = []
        while self._recv(ctypes.byref(self.rx)) == 0:
            word = int.from_bytes(bytes(self.rx.data), "little")
            if self.rx.id == AUTH_CHALLENGE:
                self.fv = (word >> 12) & 0xFFFFF
            out.append((self.rx.id, word))
        return out


def wheels_of(word: int) -> tuple[int, int, int]:
    """WHEEL_CMD: step, left, right (raw, 2^-10 rad/s)."""

    def s18(v: int) -> int:
        return v - (1 << 18) if v & (1 << 17) else v

    return (word >> 12) & 0xFFFF, s18((word >> 28) & 0x3FFFF), s18((word >> 46) & 0x3FFFF)


def param_value_of(word: int) -> tuple[int, int, float]:
    """PARAM_VALUE: index, result, value."""
    value = struct.unpack("<f", ((word >> 32) & 0xFFFFFFFF).to_bytes(4, "little"))[0]
    return (word >> 16) & 0xFF, (word >> 24) & 0xFF, value


# ------------------------------------------------------------------ one trial

SPECIAL = [
    0.0,
    -0.0,
    1e-6,
    1.4e-45,
    -1.0,
    math.nan,
    math.inf,
    -math.inf,
    3.4e38,
    1e-30,
    65536.0,
]


INDEXES = sorted(BY_INDEX)
UNKNOWN = [next(i for i in range(ARM) if i not in BY_INDEX), 127, 200, 255]
"""Indexes no row has: the first free one, and three far up."""


def random_value(rng: random.Random, index: int, now: dict[int, float]) -> float:
    """A value for PARAM_SET @p index: in range, at and across range and
    relation ends, far off, or not a number at all."""
    limit = BY_INDEX.get(index)
    pick = rng.random()
    if limit is None or pick < 0.10:
        return rng.choice(SPECIAL)
    lo, hi = limit.minimum, limit.maximum
    if pick < 0.35:
        return rng.uniform(lo, hi)
    if pick < 0.55:
        end = rng.choice((lo, hi))
        return end * rng.choice((1.0, 1 - 1e-7, 1 + 1e-7, 0.99, 1.01, 0.5, 2.0))
    if pick < 0.75:  # around another value in force: relation ends
        other = now[rng.choice(list(now))]
        return other * rng.choice((1.0, 1.25, 0.5, 2.0, 0.8)) * (1 + rng.uniform(-1e-6, 1e-6))
    if pick < 0.90:
        return math.copysign(10 ** rng.uniform(-8, 6), rng.choice((1.0, 1.0, -1.0)))
    return now.get(index, lo) * (1 + rng.gauss(0.0, 0.3))


@dataclass
class Stats:
    trials: int = 0
    moving_at_cut: int = 0
    sets: Counter[str] = field(default_factory=Counter)
    accepted: Counter[str] = field(default_factory=Counter)
    max_zero_periods: int = 0
    """Most periods from the last odometry frame to zero wheels."""


class Trial:
    """The fixed frames of every trial, built once, and one trial's counters."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        # A few reference placements: 1 m ahead (70 rad/s with the defaults),
        # 3 m ahead (saturated), 1 m to the left (turning).
        self.refs = [
            (odom_xy(1.0, 0.0), ref_motion(0.0, 0.5, 0.0)),
            (odom_xy(3.0, 0.0), ref_motion(0.0, 0.5, 0.0)),
            (odom_xy(0.0, 1.0), ref_motion(0.0, 0.5, 0.2)),
        ]
        self.sealed: dict[tuple[int, int, int], _Frame] = {}
        self.steps = [c_frame(STEP, seal(STEP, step_payload(k), k)) for k in range(200)]

    def frame(self, frame_id: int, payload: int) -> _Frame:
        counter = self.counters[frame_id]
        self.counters[frame_id] = (counter + 1) & 0xF
        key = (frame_id, payload, counter)
        f = self.sealed.get(key)
        if f is None:
            f = self.sealed[key] = c_frame(frame_id, seal(frame_id, payload, counter))
        return f

    def inputs(self, odometry: tuple[bool, bool]) -> None:
        if odometry[0]:
            self.fw.put(self.frame(ODOM_XY, odom_xy(0.0, 0.0)))
        if odometry[1]:
            self.fw.put(self.frame(ODOM_THETA, odom_theta(0.0)))
        self.fw.put(self.frame(REF_XY, self.ref[0]))
        self.fw.put(self.frame(REF_MOTION, self.ref[1]))

    def step(self, odometry: tuple[bool, bool] = (True, True)) -> tuple[tuple[int, int], int]:
        """One control step: the wheel command it answered (raw left, right)
        and STATUS_halt."""
        self.inputs(odometry)
        answers = dict(self.fw.send(self.steps[self.k]))
        step, left, right = wheels_of(answers[WHEEL_CMD])
        assert step == self.k
        self.k += 1
        return (left, right), answers[STATUS] >> 61

    def param(self, index: int, value: float, stats: Stats) -> None:
        """An authenticated PARAM_SET: the firmware answers after its PARAM_AUTH."""
        pset = seal(PARAM_SET, param_set(index, value), self.counters[PARAM_SET])
        self.counters[PARAM_SET] = (self.counters[PARAM_SET] + 1) & 0xF
        auth = seal(PARAM_AUTH, param_auth(pset, self.fw.fv + 1), self.counters[PARAM_AUTH])
        self.counters[PARAM_AUTH] = (self.counters[PARAM_AUTH] + 1) & 0xF
        self.fw.put(c_frame(PARAM_SET, pset))
        f = c_frame(PARAM_AUTH, auth)
        answer = next(param_value_of(w) for i, w in self.fw.send(f) if i == PARAM_VALUE)
        assert answer[0] == index
        result = RESULTS[answer[1]]
        name = "arm" if index == ARM else BY_INDEX[index].name if index in BY_INDEX else "unknown"
        stats.sets[result] += 1
        if result == "ok":
            stats.accepted[name] += 1
            if index in BY_INDEX and BY_INDEX[index].held:
                self.now[index] = answer[2]

    def read_back(self) -> dict[str, float]:
        values = {}
        for p in HELD:
            payload = p.index << 16
            f = c_frame(PARAM_GET, seal(PARAM_GET, payload, self.counters[PARAM_GET]))
            self.counters[PARAM_GET] = (self.counters[PARAM_GET] + 1) & 0xF
            index, result, value = next(
                param_value_of(w) for i, w in self.fw.send(f) if i == PARAM_VALUE
            )
            assert (index, result) == (p.index, 0)
            values[p.name] = value
        return values

    def random_set(self, rng: random.Random, stats: Stats) -> None:
        r = rng.random()
        if r < 0.1:
            self.param(ARM, rng.choice((1.0, 1.0, 0.0, 2.0, math.nan)), stats)
        elif r < 0.12:
            self.param(rng.choice(UNKNOWN), random_value(rng, 99, self.now), stats)
        else:
            index = rng.choice(INDEXES)
            self.param(index, random_value(rng, index, self.now), stats)

    def run(self, seed: int, stats: Stats) -> None:
        rng = random.Random(seed)
        self.fw.restart()
        self.counters = dict.fromkeys((ODOM_XY, ODOM_THETA, REF_XY, REF_MOTION, PARAM_SET), 0)
        self.counters[PARAM_GET] = 0
        self.counters[PARAM_AUTH] = 0
        self.k = 0
        self.now = {p.index: p.default for p in HELD}
        self.ref = rng.choice(self.refs)
        where = f"{self.fw.numeric} trial {seed}"
        for _ in range(5):
            self.inputs((True, True))
        for _ in range(rng.randint(1, 8)):  # parameters, armed or not
            if rng.random() < 0.3:
                self.step()
            else:
                self.random_set(rng, stats)
        if rng.random() < 0.7:
            self.param(ARM, 1.0, stats)
        for _ in range(3):
            wheels, _ = self.step()
        stats.moving_at_cut += wheels != (0, 0)
        # The cut: odometry stops for good at a random phase of this step
        # (before both frames, between them, or after ODOM_THETA only); its
        # last frame is the last one of the frame cut first, of the previous
        # step.
        last_odometry = self.k - 1
        phase = rng.randrange(3)
        self.step((phase == 1, phase == 2))
        for _ in range(AFTER_CUT):
            if rng.random() < 0.15:
                self.random_set(rng, stats)
            k = self.k
            wheels, halt = self.step((False, False))
            if wheels == (0, 0) and halt != 0:
                # Halted at zero: so it stays, as nothing re-arms without
                # odometry (the arm command needs 5 good frames in a row).
                stats.max_zero_periods = max(stats.max_zero_periods, k - last_odometry)
                break
            # The bound: 1 s after the last odometry frame, at zero.
            assert (k - last_odometry) * DT_US < STOP_S * 1e6, (
                f"{where}: wheel command {wheels} (halt {halt}) at step {k}, "
                f"{(k - last_odometry) * DT_US / 1e6:g} s after the last odometry frame"
            )
        else:
            pytest.fail(f"{where}: never halted at zero")
        held = Held.FLOAT if self.fw.numeric == "float" else Held.FIXED_FRAME
        problem = violation(self.read_back(), ways=(held,))
        assert problem is None, f"{where}: a set in force the check refuses: {problem}"
        stats.trials += 1


@pytest.mark.parametrize("numeric", ["float", "fixed"])
def test_no_parameter_sequence_keeps_the_wheels_turning_1_s_after_a_cut(numeric: str) -> None:
    var = f"MSTC_SIL_LIB_{numeric.upper()}"
    value = os.environ.get(var)
    if not value or not Path(value).is_file():
        pytest.fail(f"{var}={value!r}: `make test-python` builds both libraries", pytrace=False)
    fw = Firmware(Path(value))
    assert fw.numeric == numeric
    trial = Trial(fw)
    stats = Stats()
    start = time.perf_counter()
    for seed in range(TRIALS):
        trial.run(seed, stats)
    seconds = time.perf_counter() - start
    line = (
        f"{numeric}: {stats.trials} trials in {seconds:.1f} s; moving at the cut "
        f"{stats.moving_at_cut}; zero at most {stats.max_zero_periods} periods "
        f"({stats.max_zero_periods * DT_US / 1e6:g} s) after the last odometry frame; "
        f"PARAM_SET results {dict(stats.sets)}"
    )
    REPORT.append(line)
    print(line)
    # The sweep is not degenerate: it moved, and every answer came up.
    assert stats.moving_at_cut > TRIALS // 3, line
    assert set(stats.sets) == set(RESULTS.values()), line
    # (26 parameters share the draws since issues 19 and 20: D_s, bound by
    # two relations, is accepted about 90 times in 10,000 trials.)
    assert all(stats.accepted[p.name] > TRIALS // 200 for p in HELD), stats.accepted
