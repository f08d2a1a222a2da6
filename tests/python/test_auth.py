# SPDX-License-Identifier: MIT
"""Who may command the robot (docs/safety.md, "Threat model"), over the SIL
frame path: PARAM_SET and the arm command authenticated in the manner of
AUTOSAR SecOC (AES-128-CMAC truncated to 32 bits over the data ID, the
payload, the firmware's session and its challenge), refused and counted when
MAC-less, under another key, replayed or stale; the firmware's status
authenticated by its own MAC; odometry replayed from an earlier moment halts
the robot. (tests/python/test_auth_attacks.py plays the attacks of issue 21.)

The MACs the tests expect come from the RFC 4493 examples and from
`cryptography`'s CMAC, never from the firmware; the firmware's CMAC is
compared with `cryptography`'s on random keys and messages.
"""

from __future__ import annotations

import ctypes
import errno
import random
from collections.abc import Iterator
from pathlib import Path

import can
import pytest
from cryptography.hazmat.primitives.ciphers import algorithms
from cryptography.hazmat.primitives.cmac import CMAC

from mstc.can import secoc
from mstc.can.protocol import Frame, Protocol, wire_limits
from mstc.errors import FrameDropped
from mstc.loop.lockstep import ACCEPTED, AGAIN, REFUSED, decides, outcome
from mstc.model import wrap_angle
from mstc.plant.plant import UnicyclePlant
from mstc.plant.reference import ReferenceRobot
from mstc.plant.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
TEST_KEY = bytes.fromhex("2b7e151628aed2a6abf7158809cf4f3c")
"""RFC 4493's example key, also tests/data/test.key."""
OTHER_KEY = bytes(range(16))
ARM = 128
D_S = 4
UNAUTHENTICATED = 4
HALT_ODOMETRY_IMPLAUSIBLE = 6
RFC4493_M = bytes.fromhex(
    "6bc1bee22e409f96e93d7e117393172aae2d8a571e03ac9c9eb76fac45af8e51"
    "30c81c46a35ce411e5fbc1191a0a52eff69f2445df4f9b17ad2b417be66c3710"
)
RFC4493_T = {
    0: "bb1d6929e95937287fa37d129b756746",
    16: "070a16b46b4d4144f79bdd9dd04a287c",
    40: "dfa66747de9ae63030ca32611497c827",
    64: "51f0bebf7e3b9d92fc49741779363cfe",
}
"""RFC 4493, section 4: AES-CMAC of the first 0, 16, 40 and 64 bytes of M."""


def reference_cmac(key: bytes, data: bytes) -> bytes:
    """AES-128-CMAC by `cryptography`, the independent computation."""
    c = CMAC(algorithms.AES(key))
    c.update(data)
    return c.finalize()


# -------------------------------------------------------------------- MAC


def test_the_reference_cmac_gives_the_rfc_4493_examples() -> None:
    for n, tag in RFC4493_T.items():
        assert reference_cmac(TEST_KEY, RFC4493_M[:n]).hex() == tag


def test_the_tools_cmac_gives_the_rfc_4493_examples() -> None:
    for n, tag in RFC4493_T.items():
        assert secoc.cmac(TEST_KEY, RFC4493_M[:n]).hex() == tag


def test_the_firmware_cmac_is_the_reference_cmac(sil_lib: Path) -> None:
    lib = ctypes.CDLL(str(sil_lib.resolve()))
    fn = getattr(lib, "mstc_sil_cmac", None)
    assert fn is not None, f"{sil_lib} exports no mstc_sil_cmac"
    fn.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_size_t, ctypes.c_char_p]
    fn.restype = ctypes.c_int
    rng = random.Random(13)
    cases = [(TEST_KEY, RFC4493_M[:n]) for n in RFC4493_T]
    cases += [(rng.randbytes(16), rng.randbytes(rng.randrange(65))) for _ in range(300)]
    for key, msg in cases:
        out = ctypes.create_string_buffer(16)
        if len(msg) > 16:  # the firmware MACs one block at most (auth.h)
            assert fn(key, msg, len(msg), out) == -errno.EINVAL
            continue
        assert fn(key, msg, len(msg), out) == 0
        assert out.raw == reference_cmac(key, msg), (key.hex(), msg.hex())


SESSION = 0x5EC0A1D1
"""The session the Unity tests give the firmware (tests/unit/test_frames.h)."""


def _status(session: int, freshness: int, last: int = 0, refused: int = 0) -> secoc.Status:
    return secoc.Status(session, freshness, last, refused, False)


def test_the_mac_of_a_command_is_secoc_s() -> None:
    """Data ID, PARAM_SET bytes 2..7, session, freshness (all big-endian), MAC
    truncated to its first 4 bytes: the layout docs/protocol.md states."""
    proto = Protocol(node=None)
    auth = secoc.Authenticator(TEST_KEY)
    auth.status = _status(SESSION, 0)
    pset, pauth = auth.param_set(proto, ARM, 1.0)
    assert auth.signed == 1
    data = bytes(pset.data)
    want = reference_cmac(
        TEST_KEY,
        bytes((0x11, 0x20)) + data[2:8] + SESSION.to_bytes(4, "big") + (1).to_bytes(4, "big"),
    )
    assert want[:4].hex() == "3a4cb7e5"  # written into tests/unit/test_app_auth.c
    assert bytes(pauth.data)[4:8] == want[:4]
    f = proto.decode(pauth)
    assert f.name == "PARAM_AUTH" and f.signals["freshness"] == 1


def test_a_tool_signs_each_challenge_once() -> None:
    """Signing again for the same challenge would leave a second pair valid
    for the same moment: the tool waits for the firmware's next status."""
    from mstc.errors import AuthKeyError

    proto = Protocol(node=None)
    auth = secoc.Authenticator(TEST_KEY)
    with pytest.raises(AuthKeyError, match="no authenticated status"):
        auth.param_set(proto, ARM, 1.0)
    auth.status = _status(SESSION, 5)
    auth.param_set(proto, ARM, 1.0)
    assert not auth.can_sign()
    with pytest.raises(AuthKeyError, match="signed already"):
        auth.param_set(proto, ARM, 1.0)
    auth.status = _status(SESSION, 6)
    assert auth.can_sign()


def test_the_tool_adopts_a_status_only_when_its_mac_verifies() -> None:
    """The status MAC: AUTH_CHALLENGE's data ID 0x1187, last, refused (bit 15:
    saturated), three zero bytes, session, freshness: cryptography's CMAC."""
    proto = Protocol(node=None)
    fields = {"last": 2, "session": SESSION, "refused": 1, "refused_saturated": 0}
    status_frame = proto.decode(proto.encode("AUTH_STATUS", raw=True, **fields))
    tag = reference_cmac(
        TEST_KEY,
        bytes((0x11, 0x87, 2, 0, 1, 0, 0, 0)) + SESSION.to_bytes(4, "big") + (7).to_bytes(4, "big"),
    )[:4]
    good = proto.decode(
        proto.encode("AUTH_CHALLENGE", raw=True, freshness=7, mac=int.from_bytes(tag, "little"))
    )
    auth = secoc.Authenticator(TEST_KEY)
    assert auth.sync(status_frame) is None
    st = auth.sync(good)
    assert st == secoc.Status(SESSION, 7, 2, 1, False) and auth.freshness == 7
    # One bit of the MAC changed, or the second half without its first: nothing.
    bad = proto.decode(
        proto.encode("AUTH_CHALLENGE", raw=True, freshness=8, mac=int.from_bytes(tag, "little") ^ 1)
    )
    assert auth.sync(status_frame) is None and auth.sync(bad) is None
    assert auth.sync(good) is None
    assert auth.status == st and auth.forged == 2
    # Under another key, the firmware's genuine status does not verify.
    other = secoc.Authenticator(OTHER_KEY)
    other.sync(status_frame)
    assert other.sync(good) is None and other.status is None


# ----------------------------------------------------- commands over the bus


class Tool:
    """A tool and the plant's inputs on the in-process bus, frame by frame."""

    def __init__(self, bus: can.BusABC) -> None:
        self.bus = bus
        self.proto = Protocol(node=None)
        self.status: Frame | None = None
        self.challenge: Frame | None = None
        self.senders: list[secoc.Authenticator] = []
        """Authenticators that read every frame the firmware sends."""

    def send(self, msg: can.Message) -> list[Frame]:
        self.bus.send(msg)
        out = []
        while (m := self.bus.recv(timeout=0)) is not None:
            try:
                f = self.proto.decode(m)
            except FrameDropped:
                continue
            if f.name == "AUTH_STATUS":
                self.status = f
            if f.name == "AUTH_CHALLENGE":
                self.challenge = f
            for a in self.senders:
                a.sync(f)
            out.append(f)
        return out

    def sender(self, key: bytes) -> secoc.Authenticator:
        """An authenticator with @p key that has read the firmware's status."""
        a = secoc.Authenticator(key)
        self.senders.append(a)
        self.send(self.proto.encode("PARAM_GET", index=ARM))
        return a

    def send_all(self, msgs: list[can.Message]) -> list[Frame]:
        return [f for m in msgs for f in self.send(m)]

    def preroll(self) -> None:
        enc = self.proto.encode
        for _ in range(5):
            self.send(enc("ODOM_XY", x=0.0, y=0.0))
            self.send(enc("ODOM_THETA", theta=0.0))
            self.send(enc("REF_XY", x=1.0, y=0.0))
            self.send(enc("REF_MOTION", theta=0.0, v=0.5, w=0.0))

    def result(self, frames: list[Frame], index: int) -> int | None:
        for f in frames:
            if f.name == "PARAM_VALUE" and f.signals["index"] == index:
                return int(f.signals["result"])
        return None

    def refused(self) -> int:
        assert self.status is not None, "no AUTH_STATUS from the firmware"
        return int(self.status.signals["refused"])

    def reseal(self, msg: can.Message) -> can.Message:
        """The same payload with this sender's next alive counter and CRC: a
        replay that passes the E2E checks."""
        data = bytearray(msg.data)
        self.proto.protect(msg.arbitration_id, data)
        return can.Message(arbitration_id=msg.arbitration_id, is_extended_id=False, data=data)


@pytest.fixture
def tool(sil_lib: Path) -> Iterator[Tool]:
    with can.Bus(interface="mstc-sil", lib=str(sil_lib), key=TEST_KEY) as bus:
        yield Tool(bus)


def test_a_mac_less_arm_is_refused_and_counted(tool: Tool) -> None:
    tool.preroll()
    got = tool.send(tool.proto.encode("PARAM_SET", index=ARM, value=1.0))
    assert tool.result(got, ARM) is None, "answered before its PARAM_AUTH could come"
    got = tool.send(tool.proto.encode("PARAM_SET", index=D_S, value=0.4))  # supersedes it
    assert tool.result(got, ARM) == UNAUTHENTICATED
    got = tool.send(tool.proto.encode("PARAM_GET", index=ARM))
    assert tool.result(got, ARM) == 0
    assert next(f for f in got if f.name == "PARAM_VALUE").signals["value"] == 0.0, "not armed"
    assert tool.refused() == 1


def test_an_authenticated_arm_is_accepted_and_the_freshness_moves(tool: Tool) -> None:
    tool.preroll()
    auth = tool.sender(TEST_KEY)
    assert auth.status is not None and auth.status.freshness == 0
    got = tool.send_all(auth.param_set(tool.proto, ARM, 1.0))
    assert tool.result(got, ARM) == 0
    assert tool.challenge is not None and tool.challenge.signals["freshness"] == 1
    assert tool.status is not None and tool.status.signals["last"] == 0  # ok
    assert tool.refused() == 0


def test_wrong_key_replayed_and_stale_commands_are_refused_and_counted(tool: Tool) -> None:
    tool.preroll()
    good = tool.sender(TEST_KEY)
    # Another key: its tool cannot read the firmware's status (the MAC does
    # not verify under its key), so it signs nothing; a command of its own
    # making, for the current challenge, is refused, nothing applied.
    other = tool.sender(OTHER_KEY)
    assert other.status is None and other.forged >= 1
    other.status = good.status
    got = tool.send_all(other.param_set(tool.proto, ARM, 1.0))
    assert tool.result(got, ARM) == UNAUTHENTICATED
    assert tool.refused() == 1
    assert good.status is not None and good.status.last == 2  # mac
    # The right key: accepted, then a few more.
    first = good.param_set(tool.proto, D_S, 0.4)
    assert tool.result(tool.send_all(first), D_S) == 0
    for value in (0.41, 0.42):
        assert tool.result(tool.send_all(good.param_set(tool.proto, D_S, value)), D_S) == 0
    # The first pair recorded and replayed, E2E counters and CRCs made good:
    # its MAC is right, its challenge used up.
    got = tool.send_all([tool.reseal(m) for m in first])
    assert tool.result(got, D_S) == UNAUTHENTICATED
    assert tool.refused() == 2
    assert tool.status is not None and tool.status.signals["last"] == 3  # stale
    # A sender that missed the last decision (the challenge before): stale.
    behind = secoc.Authenticator(TEST_KEY)
    assert good.status is not None
    behind.status = secoc.Status(good.status.session, good.status.freshness - 1, 0, 0, False)
    got = tool.send_all(behind.param_set(tool.proto, D_S, 0.5))
    assert tool.result(got, D_S) == UNAUTHENTICATED
    assert tool.refused() == 3
    got = tool.send(tool.proto.encode("PARAM_GET", index=D_S))
    value = next(f for f in got if f.name == "PARAM_VALUE").signals["value"]
    assert value == pytest.approx(0.42), "only the authentic commands were applied"
    # The good sender goes on.
    assert tool.result(tool.send_all(good.param_set(tool.proto, ARM, 1.0)), ARM) == 0


def test_a_command_that_comes_after_its_challenge_expired_is_decided_by_its_own_refusal(
    tool: Tool,
) -> None:
    """docs/safety.md: a challenge unused for 0.5 s of firmware time is
    replaced at the next housekeeping (every 100 ms; outcome expired), and a
    command signed for it that comes after is refused as stale, using up the
    next challenge. The status that decides the command is that refusal's, not
    the expiry, which reached the tool first: read as the decision, the expiry
    had `mstc board set` sign again for the challenge its own late command
    then used up (each retry one behind, on the vcan VM's bridge)."""
    tool.preroll()
    auth = tool.sender(TEST_KEY)
    st0 = auth.status
    assert st0 is not None
    late = auth.param_set(tool.proto, D_S, 0.4)
    signed = auth.signed
    assert signed == st0.freshness + 1
    seen: list[secoc.Status] = []  # every status the tool adopts, in the bus's order

    def send(msg: can.Message) -> list[Frame]:
        before = auth.status
        got = tool.send(msg)
        if auth.status is not None and auth.status is not before:
            seen.append(auth.status)
        return got

    # 0.7 s of firmware time on its 20 ms steps, the command still on its way.
    for k in range(1, 36):
        send(tool.proto.encode("STEP", step=k, time=k * 20_000, raw=True))
        if any(x.last == secoc.EXPIRED for x in seen):
            break
    expiry = next(x for x in seen if x.last == secoc.EXPIRED)
    assert (expiry.session, expiry.freshness) == (st0.session, signed)
    got = [f for m in late for f in send(m)]
    assert tool.result(got, D_S) == UNAUTHENTICATED
    refusal = seen[-1]
    assert (refusal.freshness, refusal.last) == (signed + 1, secoc.STALE)
    # The first status, in order, that decides it: the refusal, not the expiry.
    decided = next(x for x in seen if decides(st0.session, signed)(x))
    assert decided == refusal
    assert outcome(st0, signed, decided, refused=True) == AGAIN
    # Signed again for the challenge after the refusal: accepted.
    got = tool.send_all(auth.param_set(tool.proto, D_S, 0.4))
    assert tool.result(got, D_S) == 0


# ------------------------------------------------------------------- odometry


def test_a_replayed_16_frame_odometry_loop_halts_over_the_sil_frame_path(sil_lib: Path) -> None:
    from mstc.loop.lockstep import CanController

    s = load_scenario(ROOT / "sim" / "scenarios" / "paper-line.toml", wire_limits())
    p = s.params
    with can.Bus(interface="mstc-sil", lib=str(sil_lib), key=TEST_KEY) as bus:
        ctl = CanController(bus, p, sim_time_stamps=True, key=TEST_KEY)
        proto = ctl.proto
        plant = UnicyclePlant(s.robot, p.wheel_radius, p.track_width, s.sim.integrator)
        ref = ReferenceRobot(s.reference.pose, s.reference.v, s.reference.w, s.sim.integrator)
        res = ctl.step(plant.pose, ref.pose, ref.v, ref.w, (), 0)
        wheels = (res.wheel_left, res.wheel_right)
        recorded: list[can.Message] = []
        halts: list[tuple[int, int]] = []
        for k in range(1, 200):
            plant.step(*wheels, s.sim.dt)
            ref.step(s.sim.dt)
            t_us = k * s.sim.dt_us
            if k < 100:  # the real sensor
                xy = proto.encode("ODOM_XY", x=plant.pose.x, y=plant.pose.y)
                th = proto.encode("ODOM_THETA", theta=wrap_angle(plant.pose.theta))
                if k >= 84:
                    recorded += [xy, th]  # one turn of the alive counter
            else:  # the recorder, playing its 16 frames of each in a loop
                j = 2 * ((k - 100) % 16)
                xy, th = recorded[j], recorded[j + 1]
            answers: list[Frame] = []
            for m in (
                xy,
                th,
                proto.encode("REF_XY", x=ref.pose.x, y=ref.pose.y),
                proto.encode("REF_MOTION", theta=wrap_angle(ref.pose.theta), v=ref.v, w=ref.w),
                proto.encode("STEP", step=k, time=t_us, raw=True),
            ):
                m.timestamp = t_us / 1e6
                bus.send(m)
                while (r := bus.recv(timeout=0)) is not None:
                    try:
                        answers.append(proto.decode(r))
                    except FrameDropped:
                        pass
            st = next(f for f in answers if f.name == "STATUS")
            cmd = next(f for f in answers if f.name == "WHEEL_CMD")
            wheels = (float(cmd.signals["left"]), float(cmd.signals["right"]))
            if st.signals["halt"] != 0:
                halts.append((k, int(st.signals["halt"])))
        assert halts, "the replayed odometry was never noticed"
        k_halt, why = halts[0]
        # The first replayed pose is 16 steps (0.16 m at 0.5 m/s) behind the
        # prediction: s = 0.16 - 0.025 m > 0.1 m (docs/safety.md).
        assert k_halt == 100, f"halt at step {k_halt}: the replay began at step 100"
        assert why == HALT_ODOMETRY_IMPLAUSIBLE
        assert all(h == HALT_ODOMETRY_IMPLAUSIBLE for _, h in halts), "the halt latches"
        assert wheels == (0.0, 0.0), "ramped down to a stop"


def test_the_outcome_of_a_signed_command_follows_the_status_that_decided_it() -> None:
    """mstc.loop.lockstep.outcome, shared by CanController and the ROS
    bridge's board, against the table of AUTH_STATUS_last (docs/protocol.md:
    0 ok, 2 mac, 3 stale): a command signed for freshness 6 in session 7."""

    def status(session: int, freshness: int, last: int) -> secoc.Status:
        return secoc.Status(session, freshness, last, 0, False)

    before = status(7, 5, 0)
    assert outcome(before, 6, status(7, 6, 0), refused=False) == ACCEPTED
    # The status says it was used, but PARAM_VALUE says unauthenticated.
    assert outcome(before, 6, status(7, 6, 0), refused=True) == REFUSED
    assert outcome(before, 6, status(7, 6, 2), refused=False) == REFUSED  # mac
    assert outcome(before, 6, status(7, 6, 3), refused=False) == AGAIN  # stale
    # Its challenge expired on its way: its own refusal decides it, one later.
    assert not decides(7, 6)(status(7, 6, secoc.EXPIRED))
    assert decides(7, 6)(status(7, 7, secoc.STALE))
    assert outcome(before, 6, status(7, 7, secoc.STALE), refused=True) == AGAIN
    assert outcome(before, 6, status(9, 0, 0), refused=False) == AGAIN  # restarted
    # Another command decided freshness 6: this one was not the one used.
    assert outcome(before, 6, status(7, 7, 0), refused=False) == REFUSED
