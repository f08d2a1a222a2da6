# SPDX-License-Identifier: MIT
"""The property of issue 21: over random interleavings of a tool's commands
with an attacker's recorded, forged and delayed frames, no command is
accepted that the tool did not intend at that time (docs/safety.md,
"Authenticated commands").

Each trial is a fresh firmware (the in-process library, both numeric modes)
on a bus shared by two nodes, run through a random sequence of events:

- the tool signs a command for the challenge of the last status it could
  verify (``secoc.Authenticator``, as ``mstc`` does) and sends its PARAM_SET,
  then its PARAM_AUTH at once or, when the attacker withholds it, later;
- the attacker sends frames of its own with good E2E (which needs no key):
  a PARAM_SET slipped between, a forged PARAM_AUTH, a forged status the tool
  reads, or any command it recorded, played again;
- control steps pass (the firmware's time: its challenge expires);
- the firmware restarts (the attacker keeps its recordings).

Every command the tool signs sets D_s to a value of its own, so an accepted
command (a PARAM_VALUE answered with any result but unauthenticated) is
known by the value in force. The property: it is one the tool signed, in the
same run of the firmware, accepted once, and within the challenge's life of
its signing (0.5 s, plus one 100 ms housekeeping period and one control
period, docs/safety.md). Expected values come from the issue's statement and
the documented life of a challenge, not from the code.

``MSTC_AUTH_TRIALS=N`` runs fewer (10,000 per numeric mode by default).
"""

from __future__ import annotations

import os
import random
from dataclasses import dataclass, field
from pathlib import Path

import can
import pytest

from mstc.can import secoc
from mstc.can.protocol import Frame, Protocol
from mstc.can.silbus import SilBus
from mstc.errors import FrameDropped

TEST_KEY = bytes.fromhex("2b7e151628aed2a6abf7158809cf4f3c")
D_S = 4
UNAUTHENTICATED = 4
DT_US = 20_000
LIFE_US = 500_000 + 100_000
"""Longest time from signing to acceptance, on the firmware's clock (the
time of its last control step): the challenge's life (0.5 s) and the
housekeeping period that replaces it."""
TRIALS = int(os.environ.get("MSTC_AUTH_TRIALS", "10000"))


@dataclass
class Signed:
    """A command the tool signed."""

    value: float
    run: int
    t_us: int
    frames: list[can.Message]


@dataclass
class Trial:
    """One trial's bus: the firmware, the tool, the attacker."""

    bus: SilBus
    rng: random.Random
    proto: Protocol
    """The tool's side: its encoders and its receivers."""
    attacker: Protocol
    """The attacker's encoders (its own alive counters)."""
    run: int = 0
    t_us: int = 0
    """The firmware's time: that of the last STEP sent (0 before one)."""
    step_k: int = 0
    signed: dict[float, Signed] = field(default_factory=dict)
    accepted: set[float] = field(default_factory=set)
    recorded: list[tuple[can.Message, can.Message]] = field(default_factory=list)
    held: can.Message | None = None

    def start(self) -> None:
        """The firmware (re)starts; the attacker keeps what it recorded."""
        self.bus.restart()
        self.run += 1
        self.t_us = 0
        self.step_k = 0
        self.tool = secoc.Authenticator(TEST_KEY)
        self.held = None

    def send(self, msg: can.Message) -> None:
        """Send @p msg; the tool reads every answer; the accepted commands
        are checked against the property."""
        self.bus.send(msg)
        get = msg.arbitration_id == self.proto.db.get_message_by_name("PARAM_GET").frame_id
        while (m := self.bus.recv(timeout=0)) is not None:
            try:
                f = self.proto.decode(m)
            except FrameDropped:
                continue
            self.tool.sync(f)
            if not get:  # a PARAM_GET's answer reads, it does not set
                self.check(f)

    def check(self, f: Frame) -> None:
        if f.name != "PARAM_VALUE" or int(f.signals["index"]) != D_S:
            return
        if int(f.signals["result"]) == UNAUTHENTICATED:
            return
        value = round(float(f.signals["value"]), 4)
        cmd = self.signed.get(value)
        assert cmd is not None, f"accepted D_s = {value}, which the tool never signed"
        assert cmd.run == self.run, f"D_s = {value} signed before a restart, accepted after it"
        assert value not in self.accepted, f"D_s = {value} accepted twice"
        assert self.t_us - cmd.t_us <= LIFE_US, (
            f"D_s = {value} accepted {(self.t_us - cmd.t_us) / 1e6:.3f} s after it was signed"
        )
        self.accepted.add(value)

    def reseal(self, msg: can.Message) -> can.Message:
        """@p msg with the attacker's next alive counter and a good CRC."""
        data = bytearray(msg.data)
        self.attacker.protect(msg.arbitration_id, data)
        return can.Message(arbitration_id=msg.arbitration_id, is_extended_id=False, data=data)

    # ------------------------------------------------------------ events

    def tool_command(self) -> None:
        if not self.tool.can_sign():
            self.send(self.proto.encode("PARAM_GET", index=D_S))
            if not self.tool.can_sign():
                return
        value = round(0.3 + 0.0001 * (len(self.signed) + 1), 4)  # D_s in [0.3, 0.5)
        frames = self.tool.param_set(self.proto, D_S, value)
        self.signed[value] = Signed(value, self.run, self.t_us, frames)
        self.recorded.append((frames[0], frames[1]))
        self.send(frames[0])
        if self.rng.random() < 0.3:
            self.held = frames[1]  # withheld by the attacker, delivered later
        else:
            self.send(frames[1])

    def deliver_held(self) -> None:
        if self.held is not None:
            self.send(self.reseal(self.held))
            self.held = None

    def slip(self) -> None:
        self.send(self.attacker.encode("PARAM_SET", index=D_S, value=0.45))

    def forge_command(self) -> None:
        fv = self.rng.choice([self.tool.freshness + 1, self.rng.randrange(1 << 20)])
        self.send(self.attacker.encode("PARAM_SET", index=D_S, value=0.46))
        self.send(
            self.attacker.encode("PARAM_AUTH", freshness=fv, mac=self.rng.getrandbits(32), raw=True)
        )

    def forge_status(self) -> None:
        """A status the tool reads (the attacker's frames reach it too)."""
        st = self.tool.status
        session = st.session if st is not None else self.rng.getrandbits(32)
        ahead = self.rng.choice([1, 5, 1 << 19])
        fv = ((st.freshness if st is not None else 0) + ahead) % (1 << 20)
        for msg in (
            self.attacker.encode(
                "AUTH_STATUS", raw=True, last=0, session=session, refused=0, refused_saturated=0
            ),
            self.attacker.encode(
                "AUTH_CHALLENGE", raw=True, freshness=fv, mac=self.rng.getrandbits(32)
            ),
        ):
            try:
                self.tool.sync(self.proto.decode(msg))
            except FrameDropped:
                pass  # the tool's E2E receiver dropped it: not read

    def replay(self) -> None:
        if self.recorded:
            pset, pauth = self.rng.choice(self.recorded)
            self.send(self.reseal(pset))
            self.send(self.reseal(pauth))

    def steps(self) -> None:
        """Control steps, the firmware's clock (lock-step: STEP frames): one
        to three, each 20 ms, 0.1 s, 0.3 s or 0.6 s after the one before."""
        for _ in range(self.rng.randint(1, 3)):
            if self.step_k > 0:
                self.t_us += self.rng.choice([DT_US, 100_000, 300_000, 600_000])
            self.send(
                self.attacker.encode("STEP", step=self.step_k % 65536, time=self.t_us, raw=True)
            )
            self.step_k += 1

    EVENTS = (
        ("tool_command", 5),
        ("deliver_held", 2),
        ("slip", 1),
        ("forge_command", 1),
        ("forge_status", 2),
        ("replay", 3),
        ("steps", 2),
        ("start", 1),
    )


@pytest.mark.parametrize("mode", ["float", "fixed"])
def test_no_command_is_accepted_that_the_tool_did_not_intend_then(
    libs: dict[str, Path], mode: str
) -> None:
    names = [n for n, _ in Trial.EVENTS]
    weights = [w for _, w in Trial.EVENTS]
    accepted = 0
    tool, attacker = Protocol(node=None), Protocol(node=None)
    with SilBus(lib=str(libs[mode]), key=TEST_KEY) as bus:
        for i in range(TRIALS):
            rng = random.Random(f"issue-21-{mode}-{i}")
            tool.reset()
            attacker.reset()
            trial = Trial(bus, rng, tool, attacker)
            trial.start()
            for name in rng.choices(names, weights, k=rng.randint(4, 12)):
                getattr(trial, name)()
            accepted += len(trial.accepted)
    # The property is not vacuous: the tool's own commands get through.
    assert accepted > TRIALS // 2, f"only {accepted} commands accepted in {TRIALS} trials"
