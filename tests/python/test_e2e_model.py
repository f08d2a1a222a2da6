# SPDX-License-Identifier: MIT
"""The firmware's E2E receiver (firmware/comm/comm.c) against an independent
model of its specification (docs/safety.md, "E2E receiver").

The model below is written from the spec's text, not from comm.c: a receiver
keeps the last alive counter of a frame with a good CRC, a window of the last
four statuses and a state among NODATA, INIT, VALID and INVALID. Sequences of
frames with the faults of a CAN link (repeat, loss of 1 to 15 frames,
reordering, insertion, delay, corruption, wrong length) and of control-step
check cycles are fed to both; every status, state and run of good frames must
be the same, event by event.

comm.c is reached through tests/codec/e2e_shim.c, compiled here with the
project's warnings into a shared library. A missing compiler fails the tests;
it never skips them.
"""

from __future__ import annotations

import ctypes
import enum
import random
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from conftest import AUTH_SOURCES, build_shim
from mstc.can.protocol import e2e_crc

ROOT = Path(__file__).resolve().parents[2]
SOURCES = [
    "tests/codec/e2e_shim.c",
    "firmware/comm/comm.c",
    "firmware/comm/mstc_dbc.c",
    *AUTH_SOURCES,
]
FRAME_ID = 0x100
"""ODOM_XY: any frame the firmware receives has the same receiver."""
DATA_ID = 0x1000 + FRAME_ID


# ------------------------------------------------------- the model (the spec)


class Status(enum.IntEnum):
    """Per-frame statuses, numbered as docs/safety.md lists them."""

    OK = 0
    OK_SOME_LOST = 1
    REPEATED = 2
    WRONG_SEQUENCE = 3
    ERROR = 4
    LENGTH = 5
    NO_NEW_DATA = 6


class State(enum.IntEnum):
    NODATA = 0
    INIT = 1
    VALID = 2
    INVALID = 3


GOOD = {Status.OK, Status.OK_SOME_LOST}
BAD = {Status.ERROR, Status.LENGTH}
WINDOW = 4
MAX_DELTA = 3
# (min ok, max err) to be VALID, per state the window is judged from.
RULES = {State.INIT: (1, 0), State.VALID: (2, 1), State.INVALID: (3, 0)}


@dataclass
class Model:
    """One identifier's receiver, as docs/safety.md specifies it."""

    last: int | None = None
    state: State = State.NODATA
    window: deque[Status] = field(default_factory=lambda: deque(maxlen=WINDOW))
    run: int = 0
    status: Status = Status.NO_NEW_DATA
    frames: int = 0
    accepted: int = 0

    def receive(self, counter: int, crc_ok: bool, length: int) -> Status:
        self.frames += 1
        if length != 8:
            st = Status.LENGTH
        elif not crc_ok:
            st = Status.ERROR
        else:
            if self.last is None:
                st = Status.OK
            else:
                step = (counter - self.last) % 16
                if step == 0:
                    st = Status.REPEATED
                elif step == 1:
                    st = Status.OK
                elif step <= MAX_DELTA:
                    st = Status.OK_SOME_LOST
                else:
                    st = Status.WRONG_SEQUENCE
            self.last = counter  # follows every frame with a good CRC
        if st in GOOD:
            self.accepted += 1
        self._judge(st)
        return st

    def cycle(self) -> bool:
        if self.frames == 0:
            self._judge(Status.NO_NEW_DATA)
        got = self.accepted > 0
        self.frames = self.accepted = 0
        return got

    def _judge(self, st: Status) -> None:
        self.status = st
        self.run = min(self.run + 1, 255) if st in GOOD else 0
        if self.state is State.NODATA:
            if st not in BAD and st is not Status.NO_NEW_DATA:
                self.state = State.INIT
                self.window.clear()
            return
        self.window.append(st)
        ok = sum(s in GOOD for s in self.window)
        err = sum(s in BAD for s in self.window)
        min_ok, max_err = RULES[self.state]
        if self.state is State.INIT and err > max_err:
            self.state = State.INVALID
        elif self.state is State.INIT:
            self.state = State.VALID if ok >= min_ok else State.INIT
        else:
            self.state = State.VALID if ok >= min_ok and err <= max_err else State.INVALID


# ------------------------------------------------------------------ comm.c


class Firmware:
    def __init__(self, path: Path) -> None:
        self.lib = ctypes.CDLL(str(path))
        self.lib.e2e_decode.argtypes = [
            ctypes.c_uint32,
            ctypes.c_uint8,
            ctypes.POINTER(ctypes.c_uint8),
        ]
        self.lib.e2e_cycle.argtypes = [ctypes.c_uint32]
        self.lib.e2e_rx.argtypes = [ctypes.c_uint32, ctypes.POINTER(ctypes.c_int)]
        self.lib.e2e_init()

    def receive(self, data: bytes, length: int) -> None:
        self.lib.e2e_decode(FRAME_ID, length, (ctypes.c_uint8 * 8)(*data))

    def cycle(self) -> bool:
        return bool(self.lib.e2e_cycle(FRAME_ID))

    def rx(self) -> tuple[Status, State, int]:
        out = (ctypes.c_int * 4)()
        assert self.lib.e2e_rx(FRAME_ID, out) == 0
        return Status(out[0]), State(out[1]), out[2]


@pytest.fixture(scope="module")
def lib(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_shim(SOURCES, tmp_path_factory.mktemp("e2e") / "libe2e_shim.so", "E2E")


# ------------------------------------------------------------ event streams

Event = tuple[str, int, bool, int]
"""("frame", counter, crc good, length) or ("cycle", 0, True, 0)."""


def frame_bytes(counter: int, crc_ok: bool, rng: random.Random) -> bytes:
    data = bytearray(rng.randbytes(8))
    data[1] = (data[1] & 0xF0) | (counter & 0x0F)
    data[0] = e2e_crc(DATA_ID, data)
    if not crc_ok:
        data[rng.randrange(8)] ^= 1 << rng.randrange(8)  # one flipped bit: always caught
    return bytes(data)


def replay(events: list[Event], fw: Firmware, seed: int) -> list[tuple[object, ...]]:
    """Feed @p events to the model and to comm.c; return the differences."""
    rng = random.Random(seed)
    model = Model()
    diffs = []
    for i, (kind, counter, crc_ok, length) in enumerate(events):
        if kind == "frame":
            model.receive(counter, crc_ok, length)
            fw.receive(frame_bytes(counter, crc_ok, rng), length)
            got_cycle = want_cycle = None
        else:
            want_cycle = model.cycle()
            got_cycle = fw.cycle()
        want = (model.status, model.state, model.run, want_cycle)
        got = (*fw.rx(), got_cycle)
        if got != want:
            diffs.append((i, events[i], "model", want, "comm.c", got))
    return diffs


def clean(n: int, start: int = 0, cycles: bool = True) -> list[Event]:
    """A sender's stream: one frame per control step, each followed by its cycle."""
    out: list[Event] = []
    for k in range(n):
        out.append(("frame", (start + k) % 16, True, 8))
        if cycles:
            out.append(("cycle", 0, True, 0))
    return out


def frames_of(events: list[Event]) -> list[Event]:
    return [e for e in events if e[0] == "frame"]


def with_cycles(frames: list[Event]) -> list[Event]:
    out: list[Event] = []
    for f in frames:
        out += [f, ("cycle", 0, True, 0)]
    return out


# -------------------------------------------------------------------- tests


@pytest.fixture
def fw(lib: Path) -> Firmware:
    return Firmware(lib)


def test_a_clean_stream_validates_after_its_second_frame(fw: Firmware) -> None:
    assert replay(clean(40), fw, 0) == []
    assert fw.rx()[1] is State.VALID


@pytest.mark.parametrize("lost", range(1, 16))
def test_loss_of_1_to_15_frames(fw: Firmware, lost: int) -> None:
    frames = frames_of(clean(30))
    stream = frames[:10] + frames[10 + lost :]
    # The lost frames' control steps see no frame: NO_NEW_DATA for each.
    events = with_cycles(stream[:10]) + [("cycle", 0, True, 0)] * lost + with_cycles(stream[10:])
    assert replay(events, fw, lost) == []


def test_repeats(fw: Firmware) -> None:
    frames = frames_of(clean(30))
    stream = []
    for i, f in enumerate(frames):
        stream.append(f)
        if i % 3 == 1:
            stream.append(f)  # the same frame again
    assert replay(with_cycles(stream), fw, 1) == []


def test_reordering(fw: Firmware) -> None:
    frames = frames_of(clean(40))
    for i in range(5, 35, 6):
        frames[i], frames[i + 1] = frames[i + 1], frames[i]
    assert replay(with_cycles(frames), fw, 2) == []


def test_insertion_of_foreign_frames(fw: Firmware) -> None:
    rng = random.Random(3)
    frames = frames_of(clean(40))
    for i in range(38, 2, -5):
        frames.insert(i, ("frame", rng.randrange(16), True, 8))
    assert replay(with_cycles(frames), fw, 3) == []


@pytest.mark.parametrize("delay", [1, 2, 3, 5, 8, 13, 16, 20])
def test_delay_of_one_frame(fw: Firmware, delay: int) -> None:
    frames = frames_of(clean(50))
    late = frames.pop(10)
    frames.insert(10 + delay, late)
    assert replay(with_cycles(frames), fw, 4) == []


def test_corruption_and_wrong_length(fw: Firmware) -> None:
    frames = frames_of(clean(40))
    frames[7] = ("frame", frames[7][1], False, 8)
    frames[8] = ("frame", frames[8][1], False, 8)
    frames[20] = ("frame", frames[20][1], True, 5)
    frames[30] = ("frame", frames[30][1], False, 8)
    assert replay(with_cycles(frames), fw, 5) == []


def test_errors_before_any_good_frame(fw: Firmware) -> None:
    events: list[Event] = [("frame", 0, False, 8), ("frame", 1, True, 3), ("cycle", 0, True, 0)]
    events += [("cycle", 0, True, 0)] * 3 + clean(10, start=4)
    assert replay(events, fw, 6) == []


@pytest.mark.parametrize("seed", range(300))
def test_random_mixes_of_every_fault(fw: Firmware, seed: int) -> None:
    """A sender at one frame per step, through a link that loses, repeats,
    reorders, delays, inserts and corrupts at random; cycles at random too
    (several frames or none between two control steps)."""
    rng = random.Random(seed)
    counter = rng.randrange(16)
    pending: list[Event] = []
    events: list[Event] = []
    for _ in range(rng.randrange(20, 80)):
        f: Event = ("frame", counter, True, 8)
        counter = (counter + 1) % 16
        r = rng.random()
        if r < 0.10:
            continue  # lost
        if r < 0.18:
            pending.append(f)  # delayed: comes later
            continue
        if r < 0.26:
            events += [f, f]  # repeated
        elif r < 0.32:
            events.append(("frame", f[1], False, 8))  # corrupted
        elif r < 0.35:
            events.append(("frame", f[1], True, rng.choice([0, 4, 7])))  # wrong length
        elif r < 0.40:
            events += [("frame", rng.randrange(16), True, 8), f]  # inserted
        else:
            events.append(f)
        if pending and rng.random() < 0.3:
            events.append(pending.pop(0))
        for _ in range(rng.choice([0, 1, 1, 1, 2])):
            events.append(("cycle", 0, True, 0))
    assert replay(events, fw, seed) == []
