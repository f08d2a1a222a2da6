# SPDX-License-Identifier: MIT
"""Reading the board's loop statistics while it runs (issue 24).

`make bench` once stopped in its PIL part with "the board ran 1001 steps on
1001 STEP frames and -1 on its timer": the harness read `frame_steps` after
the board had counted a step and `steps` before it had. These tests run the
reader against a simulated board memory that makes one write of the main
loop's (hal/stm32/main.c, after_step(), in its order) between any two
monitor commands, so every interleaving of reads and writes is reached.
The expected values are the counts of STEP frames the simulated board ran,
not anything the reader computes.
"""

from __future__ import annotations

import pytest

from mstc.cli.hil import check_lockstep, settled_stats
from mstc.errors import ControllerError, FirmwareError
from mstc.firmware.qemu import LOOP_STATS_SEQ, LOOP_STATS_WORDS, LoopStats

ADDR = 0x20000100
# Word offsets of stm32_loop_stats_t (hal/stm32/stm32_hal.h).
STEPS, OVERRUNS, LOCKSTEP, FRAME_STEPS = 0, 1, 5, 6
CYC_MIN, CYC_MAX, SUM_LO, SUM_HI = 7, 8, 9, 10
SEQ = LOOP_STATS_SEQ // 4


class Board:
    """The words of stm32_loop_stats and the main loop's writes to them, one
    write per monitor command: the order of after_step() for a step run by a
    STEP frame (hal/stm32/main.c), with or without the sequence word."""

    def __init__(self, *, seq: bool = True, cycles: int = 100) -> None:
        self.mem = [0] * (LOOP_STATS_WORDS + 1)
        self.mem[STEPS] = 1  # the real-time step before the plant's first STEP
        self.seq = seq
        self.cycles = cycles
        self.pending: list[tuple[int, int]] = []
        self.frames = 0  # STEP frames handled: what the reader must report

    def step_frame(self) -> None:
        """A STEP frame arrives: queue the writes of its after_step()."""
        m = list(self.mem)
        for i, v in self.pending:  # earlier writes still queued
            m[i] = v
        first = m[LOCKSTEP] == 0
        writes = []
        if self.seq:
            writes.append((SEQ, m[SEQ] + 1))
        writes += [(LOCKSTEP, 1), (FRAME_STEPS, m[FRAME_STEPS] + 1)]
        lo_before = 0 if first else m[SUM_LO]
        writes += [
            (CYC_MIN, self.cycles if first else min(m[CYC_MIN], self.cycles)),
            (CYC_MAX, max(0 if first else m[CYC_MAX], self.cycles)),
            (SUM_LO, lo_before + self.cycles),
            (STEPS, m[STEPS] + 1),
            (OVERRUNS, 0),
        ]
        if self.seq:
            writes.append((SEQ, m[SEQ] + 2))
        self.pending += writes
        self.frames += 1

    def write_one(self) -> None:
        if self.pending:
            i, v = self.pending.pop(0)
            self.mem[i] = v

    def words(self, addr: int, n: int) -> list[int]:
        """The monitor's `xp`: the board makes one write first."""
        self.write_one()
        i = (addr - ADDR) // 4
        return list(self.mem[i : i + n])


class Vm:
    """What settled_stats() uses of a BoardVm."""

    def __init__(self, board: Board) -> None:
        self.board = board

    def stats(self) -> LoopStats:
        return LoopStats.read(self.board.words, ADDR, timeout=0.5)


def _naive(board: Board) -> LoopStats:
    """The reader before issue 24: one read of the words, however they stand."""
    return LoopStats.from_words(board.words(ADDR, LOOP_STATS_WORDS))


def test_a_read_between_frame_steps_and_steps_is_the_torn_pair_of_the_issue() -> None:
    board = Board(seq=False)
    start = _naive(board)
    board.step_frame()
    # lockstep, frame_steps written (two commands), then the read: the board
    # has counted the step in frame_steps and not yet in steps.
    board.write_one()
    end = _naive(board)
    assert end.frame_steps - start.frame_steps == 1
    assert end.steps - start.steps == 0
    with pytest.raises(ControllerError, match=r"1 steps on 1 STEP frames and -1 on its timer"):
        check_lockstep(start, end, 1)


@pytest.mark.parametrize("lead", range(0, 12))
def test_every_copy_read_through_the_sequence_word_is_one_the_board_held(lead: int) -> None:
    """A read begun @p lead writes into a step: the copy is the state before
    the step or after it, never a mix, and the lock-step check passes on the
    settled one."""
    board = Board()
    start = LoopStats.read(board.words, ADDR)
    board.step_frame()
    for _ in range(lead):
        board.write_one()
    got = LoopStats.read(board.words, ADDR)
    before_or_after = {(start.frame_steps, start.steps), (start.frame_steps + 1, start.steps + 1)}
    assert (got.frame_steps, got.steps) in before_or_after
    end = settled_stats(Vm(board), start, 1)  # type: ignore[arg-type]
    assert end.frame_steps - start.frame_steps == 1 == board.frames
    check_lockstep(start, end, 1)


def test_a_run_of_steps_read_while_the_board_writes_is_counted_exactly() -> None:
    """1001 STEP frames, each queued while the reader is reading (the plant
    sends the next STEP as soon as it has the last WHEEL_CMD): every read
    lands inside some step's writes, and the settled copy still counts every
    step once, on the frames and not on the timer."""
    board = Board()
    vm = Vm(board)
    start = vm.stats()
    for _ in range(1001):
        board.step_frame()
        vm.stats()
    end = settled_stats(vm, start, 1001)  # type: ignore[arg-type]
    assert end.frame_steps - start.frame_steps == 1001
    assert end.steps - start.steps == 1001
    assert end.step_cycles_sum == 1001 * board.cycles
    check_lockstep(start, end, 1001)


def test_a_board_that_stays_inside_an_update_is_reported_not_read() -> None:
    board = Board()
    board.mem[SEQ] = 7  # odd: an update under way that never ends
    with pytest.raises(FirmwareError, match="kept changing"):
        LoopStats.read(board.words, ADDR, timeout=0.05)
