# SPDX-License-Identifier: MIT
"""A bus shared by the in-process firmware and a node without the key that
answers authenticated commands itself (issue 30, C2), for
test_auth_answers.py and the bridge's tests.

:class:`ForgingBus` hands every frame to the firmware (mstc-sil), takes its
answers, and lets an attacker add frames of its own among them, at any place,
before the tool reads them: the attacker sees everything that goes out (a
PARAM_SET, then its PARAM_AUTH) and every genuine answer, so it knows the
firmware's next alive counter of PARAM_VALUE and can send its own answer
under it first.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

import can

from mstc.can.protocol import COUNTER_MODULO, Protocol, e2e_crc
from mstc.can.silbus import SilBus

Attacker = Callable[[can.Message, list[can.Message]], list[can.Message]]
"""Given a frame the tool sent and the firmware's answers to it, the frames
the tool reads, in order (the answers, with forged ones among them)."""


class ForgingBus(can.BusABC):
    """The firmware in process, with @p attacker on the bus (no attacker:
    the firmware's answers as they come)."""

    def __init__(
        self, lib: Path | str, key: bytes | None = None, attacker: Attacker | None = None
    ) -> None:
        self.inner = SilBus(lib=str(lib), key=key)
        self.attacker = attacker
        self.queue: deque[can.Message] = deque()
        self.genuine: list[can.Message] = []
        """Every frame the firmware sent, in order."""
        self.channel_info = f"forging {self.inner.channel_info}"
        super().__init__(channel="forging")

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self.inner.send(msg)
        answers = []
        while (m := self.inner.recv(timeout=0)) is not None:
            answers.append(m)
        self.genuine += answers
        self.queue.extend(self.attacker(msg, answers) if self.attacker else answers)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        return (self.queue.popleft() if self.queue else None), False

    def shutdown(self) -> None:
        self.inner.shutdown()
        super().shutdown()


class Forger:
    """A node without the key that answers commands: it reads the index of
    each PARAM_SET that goes out and the alive counter of each genuine
    PARAM_VALUE, and forges PARAM_VALUE frames with good E2E under any
    counter (by default the firmware's next one)."""

    def __init__(self) -> None:
        self.proto = Protocol(node=None)
        self.id = self.proto.message("PARAM_VALUE").frame_id
        self.set_id = self.proto.message("PARAM_SET").frame_id
        self.auth_id = self.proto.message("PARAM_AUTH").frame_id
        self.index: int | None = None
        """Index of the last PARAM_SET that went out."""
        self.counter: int | None = None
        """Alive counter of the firmware's last PARAM_VALUE."""

    def watch(self, sent: can.Message, answers: list[can.Message]) -> None:
        """What the attacker reads on the bus."""
        if sent.arbitration_id == self.set_id:
            self.index = sent.data[2]
        for m in answers:
            if m.arbitration_id == self.id:
                self.counter = m.data[1] & 0x0F

    def answer(self, result: int, value: float, counter: int | None = None) -> can.Message:
        """A PARAM_VALUE about the last PARAM_SET's index, under @p counter
        (default: the firmware's next)."""
        assert self.index is not None
        msg = self.proto.encode(
            "PARAM_VALUE", index=self.index, result=result, value=value, raw=True
        )
        if counter is None:
            counter = ((self.counter if self.counter is not None else -1) + 1) % COUNTER_MODULO
        data = bytearray(msg.data)
        data[1] = (data[1] & 0xF0) | counter
        data[0] = e2e_crc(self.proto.data_id(self.id), data)
        msg.data = data
        return msg


def first(forger: Forger, result: int, value: float, index: int | None = None) -> Attacker:
    """The attack of issue 30: each PARAM_AUTH (of parameter @p index, or
    any) is answered at once with @p result and @p value under the
    firmware's next counter, before the firmware's own answer."""

    def attack(sent: can.Message, answers: list[can.Message]) -> list[can.Message]:
        forger.watch(sent, [])
        out = list(answers)
        if sent.arbitration_id == forger.auth_id and index in (None, forger.index):
            out.insert(0, forger.answer(result, value))
        forger.watch(sent, answers)
        return out

    return attack


def frames_of(bus: Any, name: str, proto: Protocol) -> list[can.Message]:
    """The genuine frames @p name the firmware sent on @p bus."""
    frame_id = proto.message(name).frame_id
    return [m for m in bus.genuine if m.arbitration_id == frame_id]
