# SPDX-License-Identifier: MIT
"""A node on the bus without the key must not get a command accepted
(issue 21, cases 1 to 4; docs/safety.md, "Threat model").

Each test plays the attacker of the issue over the SIL frame path: a node that
sees every frame, keeps what it likes, sends frames of its own with good E2E
CRCs and counters (which need no key) and plays recorded frames again. The
tool is the tools' own sender of commands (:class:`mstc.can.secoc.Authenticator`,
which ``CanController`` and ``RealtimeLink`` use). Whatever the mechanism,
what must hold is the issue's: a command is accepted only when the tool sent
it for that moment: never after a reset, never after a later command or a
refusal, never after a set time.

Whether the robot is armed is read from the firmware itself (PARAM_GET of the
arm index answers 1 while armed), never from an answer an attacker could
forge.
"""

from __future__ import annotations

import random
from collections.abc import Iterator
from pathlib import Path

import can
import pytest

from mstc.can.protocol import Frame, FrameDropped, Protocol

TEST_KEY = bytes.fromhex("2b7e151628aed2a6abf7158809cf4f3c")
"""RFC 4493's example key, also tests/data/test.key."""
ARM = 128
D_S = 4
UNAUTHENTICATED = 4


class Bus:
    """The firmware (the in-process library) on a bus shared by a tool and an
    attacker: every frame the firmware sends is seen by both; what either
    sends reaches the firmware. The attacker records every frame."""

    def __init__(self, sil_lib: Path, key: bytes = TEST_KEY) -> None:
        self.lib = sil_lib
        self.key = key
        self.bus = can.Bus(interface="mstc-sil", lib=str(sil_lib), key=key)
        self.proto = Protocol(node=None)
        self.recorded: list[can.Message] = []
        """Every frame that crossed the bus, in order."""
        self.seen: list[Frame] = []
        """Every firmware frame decoded since the last send."""
        self.step_k = 0
        self.t_us = 0

    def close(self) -> None:
        self.bus.shutdown()

    def reset(self) -> None:
        """The firmware restarts (power cycle, watchdog): a new instance with
        the same key; what was recorded stays recorded."""
        self.bus.shutdown()
        self.bus = can.Bus(interface="mstc-sil", lib=str(self.lib), key=self.key)
        self.step_k = 0
        self.t_us = 0

    def send(self, msg: can.Message) -> list[Frame]:
        """Send @p msg; the firmware's answers, decoded."""
        self.recorded.append(msg)
        self.bus.send(msg)
        out: list[Frame] = []
        while (m := self.bus.recv(timeout=0)) is not None:
            self.recorded.append(m)
            try:
                out.append(self.proto.decode(m))
            except FrameDropped:
                continue
        self.seen = out
        return out

    def send_all(self, msgs: list[can.Message]) -> list[Frame]:
        return [f for m in msgs for f in self.send(m)]

    def reseal(self, msg: can.Message) -> can.Message:
        """@p msg's payload with the sender's next alive counter and a good CRC:
        what a node without the key can do to any recorded frame."""
        data = bytearray(msg.data)
        self.proto.protect(msg.arbitration_id, data)
        return can.Message(arbitration_id=msg.arbitration_id, is_extended_id=False, data=data)

    def inputs(self) -> list[Frame]:
        """One sample of the plant's inputs: the robot at rest at the origin,
        the reference ahead of it."""
        enc = self.proto.encode
        out: list[Frame] = []
        for m in (
            enc("ODOM_XY", x=0.0, y=0.0),
            enc("ODOM_THETA", theta=0.0),
            enc("REF_XY", x=1.0, y=0.0),
            enc("REF_MOTION", theta=0.0, v=0.5, w=0.0),
        ):
            out += self.send(m)
        return out

    def preroll(self) -> None:
        for _ in range(5):
            self.inputs()

    def step(self, dt_us: int = 20000) -> list[Frame]:
        """One lock-step control step with fresh inputs, @p dt_us after the
        previous one."""
        out = self.inputs()
        out += self.send(
            self.proto.encode("STEP", step=self.step_k % 65536, time=self.t_us, raw=True)
        )
        self.step_k += 1
        self.t_us += dt_us
        return out

    def armed(self) -> bool:
        """Whether the firmware is armed, read from it (PARAM_GET arm)."""
        got = self.send(self.proto.encode("PARAM_GET", index=ARM))
        value = next(
            f for f in got if f.name == "PARAM_VALUE" and f.signals["index"] == ARM
        ).signals["value"]
        return bool(value == 1.0)

    def value(self, index: int) -> float:
        got = self.send(self.proto.encode("PARAM_GET", index=index))
        return float(
            next(f for f in got if f.name == "PARAM_VALUE" and f.signals["index"] == index).signals[
                "value"
            ]
        )

    def auth_frames(self, frames: list[Frame]) -> list[Frame]:
        """The firmware's authentication state frames among @p frames
        (AUTH_STATUS and whatever goes with it)."""
        return [f for f in frames if f.name.startswith("AUTH_")]


def result(frames: list[Frame], index: int) -> int | None:
    """The result of the last PARAM_VALUE about @p index among @p frames."""
    got = [f for f in frames if f.name == "PARAM_VALUE" and f.signals["index"] == index]
    return int(got[-1].signals["result"]) if got else None


def status(frames: list[Frame]) -> Frame:
    """The last AUTH_STATUS among @p frames."""
    return [f for f in frames if f.name == "AUTH_STATUS"][-1]


class Tool:
    """An operator's tool: the tools' sender of commands, which learns the
    firmware's authentication state from the frames it receives."""

    def __init__(self, bus: Bus) -> None:
        from mstc.can import secoc

        self.bus = bus
        self.auth = secoc.Authenticator(TEST_KEY)
        self.sync()

    def take(self, frames: list[Frame]) -> None:
        """Every frame the tool receives goes through the tool's receive path
        (CanController._recv and RealtimeLink.take pass them to sync)."""
        for f in frames:
            self.auth.sync(f)

    def sync(self) -> None:
        """What the tools do before their first command: a PARAM_GET, whose
        answer carries the authentication state."""
        self.take(self.bus.send(self.bus.proto.encode("PARAM_GET", index=ARM)))

    def command(self, index: int, value: float) -> tuple[list[can.Message], list[Frame]]:
        """The tool's command, sent after reading the firmware's state (as
        the tools do when they have no fresh one); the frames it is made of
        and the answers."""
        self.sync()
        msgs = self.auth.param_set(self.bus.proto, index, value)
        got = self.bus.send_all(msgs)
        self.take(got)
        return msgs, got


@pytest.fixture
def bus(sil_lib: Path) -> Iterator[Bus]:
    b = Bus(sil_lib)
    yield b
    b.close()


def forged(bus: Bus, genuine: list[Frame], ahead: int) -> list[can.Message]:
    """What a node without the key sends as the firmware's authentication
    state: each of the firmware's AUTH_* frames in @p genuine, copied, with
    its freshness moved @p ahead and any MAC replaced by random bits; E2E
    counter and CRC made good."""
    rng = random.Random(ahead)
    out = []
    for f in bus.auth_frames(genuine):
        fields = dict(f.signals)
        if "freshness" in fields:
            bits = (
                bus.proto.db.get_message_by_name(f.name)
                .get_signal_by_name(f"{f.name}_freshness")
                .length
            )
            fields["freshness"] = (int(fields["freshness"]) + ahead) % (1 << bits)
        if "mac" in fields:
            fields["mac"] = rng.getrandbits(32)
        msg = bus.proto.encode(f.name, raw=True, **fields)
        out.append(bus.reseal(msg))
    return out


def replay_every_command(bus: Bus, sent: list[can.Message]) -> None:
    """The attacker plays every PARAM_SET it recorded, each with the
    PARAM_AUTH that followed it, E2E made good."""
    ids = {bus.proto.db.get_message_by_name(n).frame_id: n for n in ("PARAM_SET", "PARAM_AUTH")}
    pairs = [
        (a, b)
        for a, b in zip(sent, sent[1:], strict=False)
        if ids.get(a.arbitration_id) == "PARAM_SET" and ids.get(b.arbitration_id) == "PARAM_AUTH"
    ]
    assert pairs, "the attacker recorded no command"
    for a, b in pairs:
        bus.send_all([bus.reseal(a), bus.reseal(b)])


# ------------------------------------------------------------------ case 1


def test_a_forged_status_does_not_make_the_tool_sign_a_command_for_later(bus: Bus) -> None:
    """Issue 21, case 1: a forged AUTH_STATUS 2^20 ahead just before the tool
    arms; the operator retries, runs and disarms; the attacker then plays
    every command it kept. None may arm the robot."""
    bus.preroll()
    tool = Tool(bus)
    genuine = bus.seen
    # The attacker's status reaches the tool just before it arms.
    tool.take([bus.proto.decode(m) for m in forged(bus, genuine, 1 << 20)])
    tool.command(ARM, 1.0)
    if not bus.armed():
        # The operator retries with a tool started afresh.
        tool = Tool(bus)
        tool.command(ARM, 1.0)
    assert bus.armed(), "the operator's own arm command was not accepted"
    for _ in range(10):
        bus.step()
    tool.command(ARM, 0.0)
    assert not bus.armed()
    for _ in range(50):  # a second later
        bus.step()
    replay_every_command(bus, bus.recorded[:])
    assert not bus.armed(), "a command the attacker kept armed the robot after the disarm"


# ------------------------------------------------------------------ case 2


def test_a_param_set_slipped_into_the_exchange_leaves_no_pair_to_replay(bus: Bus) -> None:
    """Issue 21, case 2: a node's PARAM_SET between the tool's PARAM_SET arm = 1
    and its PARAM_AUTH; the tool's pair played a second later must not arm."""
    bus.preroll()
    tool = Tool(bus)
    pset, pauth = tool.auth.param_set(bus.proto, ARM, 1.0)
    got = bus.send(pset)
    got += bus.send(bus.proto.encode("PARAM_SET", index=D_S, value=0.4))  # the attacker's
    got += bus.send(pauth)
    tool.take(got)
    assert not bus.armed()
    for _ in range(50):
        bus.step()
    bus.send_all([bus.reseal(pset), bus.reseal(pauth)])
    assert not bus.armed(), "the tool's pair, never used up, armed the robot a second later"


def test_two_tools_interleaving_leave_no_pair_to_replay(bus: Bus) -> None:
    """Two honest tools whose exchanges interleave by accident (one arms, the
    other sets D_s): neither pair may be accepted when played again later."""
    bus.preroll()
    a, b = Tool(bus), Tool(bus)
    d_s = bus.value(D_S)
    a_set, a_auth = a.auth.param_set(bus.proto, ARM, 1.0)
    b_set, b_auth = b.auth.param_set(bus.proto, D_S, 0.4)
    got = bus.send_all([a_set, b_set, a_auth, b_auth])
    a.take(got)
    b.take(got)
    assert not bus.armed() and bus.value(D_S) == pytest.approx(d_s)
    for _ in range(50):
        bus.step()
    for s, t in ((a_set, a_auth), (b_set, b_auth)):
        bus.send_all([bus.reseal(s), bus.reseal(t)])
    assert not bus.armed(), "the first tool's pair armed the robot when played later"
    assert bus.value(D_S) == pytest.approx(d_s), "the second tool's pair was applied later"


# ------------------------------------------------------------------ case 3


def test_a_command_recorded_before_a_reset_is_refused_after_it(bus: Bus) -> None:
    """Issue 21, case 3: an arm command recorded in one run of the firmware,
    played after the firmware restarts (a board reset before the next run, as
    docs/hil.md asks), must not arm it."""
    bus.preroll()
    tool = Tool(bus)
    tool.command(D_S, 0.4)
    msgs, _ = tool.command(ARM, 1.0)
    assert bus.armed()
    bus.reset()
    bus.preroll()
    # Every recorded command, first to last, as the attacker would try them.
    replay_every_command(bus, bus.recorded[:])
    assert not bus.armed(), "an arm command recorded before the reset armed the firmware after it"
    assert bus.value(D_S) != pytest.approx(0.4), "a recorded PARAM_SET applied after the reset"


def test_simulation_targets_never_sign_with_the_device_key() -> None:
    """Issue 21, case 3: `make sim`, `make hil` and `make pil` sign with a key
    of their own, never with KEY_FILE (the device's)."""
    import subprocess

    root = Path(__file__).resolve().parents[2]
    device = "/nonexistent/device-key-of-issue-21.key"
    for target in ("sim", "hil", "pil"):
        r = subprocess.run(
            ["make", "-n", "-C", str(root), target, f"KEY_FILE={device}"],
            capture_output=True,
            text=True,
            timeout=60,
        )
        commands = r.stdout + r.stderr
        assert "--key-file" in commands, f"make {target} names no key:\n{commands[-2000:]}"
        assert device not in commands, f"make {target} signs with the device key KEY_FILE"


# ------------------------------------------------------------------ case 4


def test_a_brute_force_is_slowed_and_counted_honestly(bus: Bus) -> None:
    """Issue 21, case 4: 10,000 forged tries at bus speed. Few of them may
    even be checked (a lockout or a rate limit), the count the firmware
    reports must not stop at a ceiling without saying so, and the tool's
    genuine command must get through again once the lockout is over."""
    bus.preroll()
    tool = Tool(bus)
    rng = random.Random(21)
    tries = 10_000
    checked = 0  # tries refused for their MAC: the ones that teach a forger anything
    last: Frame | None = None
    for _ in range(tries):
        tool.sync()  # the attacker reads the state as the tool does
        fv = tool.auth.freshness + 1
        pset = bus.proto.encode("PARAM_SET", index=ARM, value=1.0)
        pauth = bus.proto.encode(
            "PARAM_AUTH",
            freshness=fv & ((1 << 20) - 1),
            mac=rng.getrandbits(32),
            raw=True,
        )
        got = bus.send_all([pset, pauth])
        assert result(got, ARM) == UNAUTHENTICATED
        last = status(got)
        checked += int(last.signals["last"]) == 2  # mac
    assert last is not None
    assert not bus.armed()
    assert checked <= 10, f"{checked} of {tries} forged MACs were checked: no rate limit"
    refused = int(last.signals["refused"])
    saturated = bool(last.signals.get("refused_saturated", 0))
    assert refused == tries or saturated, (
        f"AUTH_STATUS says {refused} refused after {tries}, and no flag says it saturated"
    )
    # Locked: the tool's own command is refused too ...
    tool.sync()
    _, got = tool.command(ARM, 1.0)
    assert not bus.armed()
    # ... until the lockout is over (at most a minute of firmware time).
    for _ in range(60 * 50):
        bus.step()
    tool.sync()
    tool.command(ARM, 1.0)
    assert bus.armed(), "the tool's genuine command was still refused a minute later"
