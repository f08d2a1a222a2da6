# SPDX-License-Identifier: MIT
"""The tools trust only authenticated answers (issue 30, C2).

The answer to an authenticated command, PARAM_VALUE, carries no MAC: a node
without the key sees PARAM_AUTH go out and answers first, with "ok" and the
firmware's next alive counter, so that the tool's E2E receiver then drops the
firmware's own answer as a repeat. Here the firmware (mstc-sil, both numeric
modes for the property) shares a bus with such a node (forging_bus.py). A
forged answer must neither confirm a command (the tool says done only what
the firmware answered) nor make the firmware's answer be dropped.

Expected values: the firmware's own PARAM_VALUE, taken off the bus before
the attacker's frames are mixed in (the ground truth); "armed" for a control
law parameter while armed (docs/safety.md, "Parameters").
"""

from __future__ import annotations

import os
import random
from pathlib import Path

import can
import pytest

from forging_bus import Attacker, Forger, ForgingBus, first, frames_of
from mstc.can.protocol import Frame, Protocol
from mstc.errors import ControllerError
from mstc.loop.lockstep import CanController
from mstc.model import Params, Pose
from mstc.ros.board import Board

TEST_KEY = bytes.fromhex("2b7e151628aed2a6abf7158809cf4f3c")
TRIALS = int(os.environ.get("MSTC_AUTH_TRIALS", "10000")) // 20
"""Trials of the property per numeric mode (500 by default; MSTC_AUTH_TRIALS
scales it with test_auth_property.py's)."""


def board_on(bus: ForgingBus) -> Board:
    board = Board(bus, TEST_KEY, lambda _f: None, answers_in_send=True, timeout=0.2)
    board.start()
    return board


def arm(board: Board) -> None:
    """Five good frames of each input, then the arm command (docs/safety.md)."""
    for _ in range(5):
        board.send(board.odometry(Pose(0, 0, 0)) + board.reference(Pose(1, 0, 0), 0.5, 0.0))
    answer = board.command(board.tables.arm_index, 1.0)
    assert answer.signals["result"] == board.tables.param_ok


def genuine_answer(bus: ForgingBus, proto: Protocol, index: int) -> tuple[int, float]:
    """Result and value of the firmware's last PARAM_VALUE about @p index."""
    for msg in reversed(frames_of(bus, "PARAM_VALUE", proto)):
        signals = proto.message("PARAM_VALUE").decode(bytes(msg.data), decode_choices=False)
        if int(signals["PARAM_VALUE_index"]) == index:
            return int(signals["PARAM_VALUE_result"]), float(signals["PARAM_VALUE_value"])
    raise AssertionError(f"the firmware never answered about parameter {index}")


def test_a_forged_ok_does_not_confirm_a_command_the_firmware_refused(sil_lib: Path) -> None:
    """The issue's case: while armed, max_wheel_speed = 50; the firmware
    answers "armed" (it keeps 100), a node answers "ok" first."""
    forger = Forger()
    proto = Protocol(node=None)
    ok = proto.tables.param_ok
    index = proto.tables.param_index.value("max_wheel_speed")
    bus = ForgingBus(sil_lib, TEST_KEY, first(forger, ok, 50.0, index=index))
    try:
        board = board_on(bus)
        arm(board)
        with pytest.raises(ControllerError) as refused:
            board.command(index, 50.0)
        assert "PARAM_VALUE" in str(refused.value) and "forge" in str(refused.value)
        result, value = genuine_answer(bus, proto, index)
        assert proto.tables.param_result.name_of(result) == "armed" and value == 100.0
    finally:
        bus.shutdown()


def test_a_forged_ok_does_not_confirm_a_command_of_the_lock_step_loop(sil_lib: Path) -> None:
    """The same attack on mstc's lock-step loop (CanController, which
    configures the firmware before a run): D_s = 100 is out of its range
    (0.05 to 60 m, docs/safety.md), the firmware answers out_of_range, a
    node answers "ok" first."""
    forger = Forger()
    proto = Protocol(node=None)
    bus = ForgingBus(sil_lib, TEST_KEY)
    try:
        controller = CanController(bus, Params(), timeout=0.2, key=TEST_KEY)
        index = proto.tables.param_index.value("D_s")
        bus.attacker = first(forger, proto.tables.param_ok, 100.0, index=index)
        with pytest.raises(ControllerError) as refused:
            controller.command(index, 100.0, "PARAM_SET D_s")
        assert "forge" in str(refused.value)
        result, _ = genuine_answer(bus, proto, index)
        assert proto.tables.param_result.name_of(result) == "out_of_range"
    finally:
        bus.shutdown()


def random_attack(
    rng: random.Random, forger: Forger, value: float, results: list[int], forged: list[can.Message]
) -> Attacker:
    """After each PARAM_AUTH, zero to three answers of the attacker's own
    (kept in @p forged) at random places among the firmware's answers: any
    result, the command's @p value or another, under the firmware's next
    counter or any."""

    def attack(sent: can.Message, answers: list[can.Message]) -> list[can.Message]:
        forger.watch(sent, [])
        out = list(answers)
        if sent.arbitration_id == forger.auth_id:
            for _ in range(rng.choice([0, 1, 1, 2, 3])):
                msg = forger.answer(
                    rng.choice([results[0], rng.choice(results)]),
                    rng.choice([value, 100.0, 0.35]),
                    rng.choice([None, rng.randrange(16)]),
                )
                forged.append(msg)
                out.insert(rng.randint(0, len(out)), msg)
        forger.watch(sent, answers)
        return out

    return attack


@pytest.mark.parametrize("mode", ["float", "fixed"])
def test_no_forged_answer_confirms_a_command_or_hides_the_firmwares(
    libs: dict[str, Path], mode: str
) -> None:
    """Over random interleavings: each trial a fresh firmware, armed or not,
    and a command the firmware accepts (D_s 0.3..0.45), refuses as armed
    (D_s while armed, max_wheel_speed) or as out of range (D_s 100); the
    attacker stays quiet, or sends one to three answers of its own (any
    result, the command's value or another, the firmware's next counter or
    any) at any places among the firmware's answers, before or after them.
    Whatever the tool reports as the firmware's answer is the firmware's
    answer; and when the attacker's answers all equal the firmware's (or it
    sent none, one trial in five), the tool reports it."""
    proto = Protocol(node=None)
    tables = proto.tables
    d_s = tables.param_index.value("D_s")
    speed = tables.param_index.value("max_wheel_speed")
    results = sorted(tables.param_result.entries)
    reported = 0
    bus = ForgingBus(libs[mode], TEST_KEY)
    try:
        for trial in range(TRIALS):
            rng = random.Random(f"issue-30-c2-{mode}-{trial}")
            bus.inner.restart()
            bus.attacker = None
            bus.queue.clear()
            board = board_on(bus)
            if rng.random() < 0.5:
                arm(board)
            index, value = rng.choice([(d_s, round(rng.uniform(0.3, 0.45), 3)), (d_s, 100.0)])
            if rng.random() < 0.3:
                index, value = speed, 50.0
            forged: list[can.Message] = []
            bus.attacker = random_attack(rng, Forger(), value, results, forged)
            start = len(frames_of(bus, "PARAM_VALUE", proto))
            try:
                answer: Frame | None = board.command(index, value)
            except ControllerError:
                answer = None
            mine = frames_of(bus, "PARAM_VALUE", proto)[start:]
            assert len(mine) == 1, f"trial {trial}: {len(mine)} genuine answers"
            truth = bytes(mine[0].data[2:8])
            if answer is not None:
                reported += 1
                got = proto.encode(
                    "PARAM_VALUE",
                    index=answer.signals["index"],
                    result=answer.signals["result"],
                    value=answer.signals["value"],
                    raw=True,
                )
                assert bytes(got.data[2:8]) == truth, (
                    f"trial {trial}: the tool reports {answer.signals}, the firmware answered "
                    f"{genuine_answer(bus, proto, index)}"
                )
            elif all(bytes(m.data[2:8]) == truth for m in forged):
                pytest.fail(f"trial {trial}: the firmware's answer was lost ({len(forged)} forged)")
    finally:
        bus.shutdown()
    assert reported > TRIALS // 10, f"only {reported} of {TRIALS} commands reported"
