# SPDX-License-Identifier: MIT
"""Authenticated commands, in the manner of AUTOSAR SecOC (docs/safety.md).

The tools' side of ``firmware/auth``: every PARAM_SET (parameters and the arm
command) is followed by a PARAM_AUTH frame carrying the 20-bit freshness
value and the first 4 bytes of

    AES-128-CMAC(key, data_id[2] || PARAM_SET bytes 2..7 || session[4] || freshness[4])

with the data ID (PARAM_SET's ``E2EDataID``, 0x1120) and the numbers
big-endian. The firmware accepts only its **challenge**, the freshness value
after the last one it decided, in the session it drew at its start; every
decision uses the challenge up. It announces both in its status, AUTH_STATUS
followed by AUTH_CHALLENGE, whose MAC (the same layout under AUTH_CHALLENGE's
data ID) authenticates the two: a tool adopts a status only when that MAC
verifies (:meth:`Authenticator.sync`), and signs each challenge once, so it
never signs a command for a moment a node without the key made up.

CMAC is ``cryptography``'s. The key is 16 bytes, per device, never committed:
:func:`load_key` finds it (an explicit file, ``$MSTC_KEY``, ``$MSTC_KEY_FILE``,
then ``keys/device.key``, which ``make key`` generates). Simulations use a
key of their own, ``keys/sim.key`` (:data:`SIM_KEY_FILE`), never a device's.
``tests/data/test.key`` is a published test key (RFC 4493's example key) for
the tests and the committed logs: never flash it.
"""

from __future__ import annotations

import hmac
import os
import re
import stat
import sys
from dataclasses import dataclass
from pathlib import Path

import can
from cryptography.hazmat.primitives.ciphers import algorithms
from cryptography.hazmat.primitives.cmac import CMAC

from mstc.can.protocol import Frame, Protocol
from mstc.errors import AuthKeyError

ROOT = Path(__file__).resolve().parents[3]
"""The repository."""
KEY_LEN = 16
"""AES-128 key length [bytes]."""
MAC_LEN = 4
"""Bytes of the CMAC that PARAM_AUTH and AUTH_CHALLENGE carry."""
FV_BITS = 20
"""Bits of the freshness value: PARAM_AUTH and AUTH_CHALLENGE carry it whole."""
FV_MAX = (1 << FV_BITS) - 1
"""The last freshness value of a session; the firmware then draws a new one."""
STATUS_DATA_ID = 0x1187
"""AUTH_CHALLENGE's ``E2EDataID``: the data ID of the firmware's status MAC."""
KEY_ENV = "MSTC_KEY"
"""Environment variable holding a key as 32 hex digits."""
KEY_FILE_ENV = "MSTC_KEY_FILE"
"""Environment variable naming a key file."""
DEFAULT_KEY_FILE = ROOT / "keys" / "device.key"
"""The device key `make key` generates (git-ignored)."""
SIM_KEY_FILE = ROOT / "keys" / "sim.key"
"""The simulations' key (git-ignored, generated like the device key): `make
sim`, `make hil`, `make pil` and the benchmarks sign with it, never with a
device's, so that no simulation's bus.log holds a command a board accepts."""
TEST_KEY_FILE = ROOT / "tests" / "data" / "test.key"
"""The published test key of the tests and the committed logs."""


_BLANKS = re.compile(r"[ \t\r\v\f]")
"""What a key ignores between its digits: C's isspace() but the line end."""


def parse_key(text: str, source: str) -> bytes:
    """The key in @p text: 32 hex digits, blanks and line ends anywhere
    ignored; a line whose first non-blank character is ``#`` is a comment.
    mstc-fw (hal/linux/main.c) and tools/setup/device-key read the same
    format (docs/safety.md, "The key"; tests/python/test_key_parsers.py).

    :raises AuthKeyError: anything else, naming @p source.
    """
    lines = (_BLANKS.sub("", line) for line in text.split("\n"))
    digits = "".join(line for line in lines if not line.startswith("#"))
    if not re.fullmatch(r"[0-9a-fA-F]{32}", digits):
        raise AuthKeyError(
            f"{source}: expected 32 hex digits (an AES-128 key), got {len(digits)} characters"
        )
    return bytes.fromhex(digits)


def read_key(path: Path) -> bytes:
    """The key in file @p path (see :func:`parse_key`); a warning on stderr
    when others than its owner may read it (but for the published test key)."""
    try:
        text = path.read_text()
        mode = path.stat().st_mode
    except OSError as exc:
        raise AuthKeyError(f"cannot read key file {path}: {exc.strerror}") from exc
    if mode & (stat.S_IRWXG | stat.S_IRWXO) and path.resolve() != TEST_KEY_FILE:
        print(
            f"warning: key file {path} is readable by others (mode {stat.filemode(mode)}): "
            f"chmod 600 {path}",
            file=sys.stderr,
        )
    return parse_key(text, str(path))


def key_file(path: Path | None = None, default: Path = DEFAULT_KEY_FILE) -> Path | None:
    """The file :func:`load_key` takes the key from, None when it takes it
    from ``$MSTC_KEY``."""
    if path is not None:
        return path
    if os.environ.get(KEY_ENV):
        return None
    if os.environ.get(KEY_FILE_ENV):
        return Path(os.environ[KEY_FILE_ENV])
    return default


def load_key(path: Path | None = None, default: Path = DEFAULT_KEY_FILE) -> bytes:
    """The key to use: @p path if given, else ``$MSTC_KEY`` (hex), else the
    file ``$MSTC_KEY_FILE``, else @p default: ``keys/device.key`` for a board,
    :data:`SIM_KEY_FILE` for a simulation (which never signs with a device's).

    :raises AuthKeyError: none found, or not a key.
    """
    source = key_file(path, default)
    if source is None:
        return parse_key(os.environ[KEY_ENV], f"${KEY_ENV}")
    if source == default and not source.is_file():
        raise AuthKeyError(
            f"no key: {default} does not exist (`make key` generates it), "
            f"and neither {KEY_ENV} nor {KEY_FILE_ENV} is set (docs/safety.md, 'The key')"
        )
    return read_key(source)


def cmac(key: bytes, data: bytes) -> bytes:
    """AES-128-CMAC (RFC 4493) of @p data under @p key: 16 bytes."""
    c = CMAC(algorithms.AES(key))
    c.update(data)
    return c.finalize()


def mac_input(data_id: int, data: bytes, session: int, freshness: int) -> bytes:
    """SecOC's DataToAuthenticator: data ID, the 6 authenticated bytes, session,
    freshness (16 bytes, one AES block)."""
    return (
        data_id.to_bytes(2, "big")
        + bytes(data)
        + session.to_bytes(4, "big")
        + freshness.to_bytes(4, "big")
    )


@dataclass(frozen=True)
class Status:
    """The firmware's authentication state, from a status whose MAC verified."""

    session: int
    """Drawn at the firmware's start."""
    freshness: int
    """The freshness value last decided: the challenge is this + 1."""
    last: int
    """How it was decided (AUTH_STATUS_last: 0 ok, 1 missing, 2 mac, 3 stale,
    4 no_key, 5 locked, 6 expired)."""
    refused: int
    """Commands refused since the firmware's start, up to 32767."""
    saturated: bool
    """More than 32767 were refused."""

    def data(self) -> bytes:
        """The 6 bytes the status MAC covers in place of a command's data."""
        refused = self.refused | (0x8000 if self.saturated else 0)
        return bytes((self.last,)) + refused.to_bytes(2, "big") + bytes(3)


def status_mac(key: bytes, status: Status) -> bytes:
    """The firmware's MAC of @p status (AUTH_CHALLENGE bytes 4..7)."""
    return cmac(key, mac_input(STATUS_DATA_ID, status.data(), status.session, status.freshness))[
        :MAC_LEN
    ]


class Authenticator:
    """A sender of authenticated commands.

    It learns the firmware's session and challenge from the status frames it
    is given (:meth:`sync`), adopting a status only when its MAC verifies, and
    signs each challenge once (:meth:`param_set`).

    :param key: the firmware's key.
    """

    def __init__(self, key: bytes) -> None:
        if len(key) != KEY_LEN:
            raise AuthKeyError(f"a key is {KEY_LEN} bytes, not {len(key)}")
        self.key = key
        self.status: Status | None = None
        """The last status whose MAC verified; None before the first."""
        self.forged = 0
        """Status frames that did not verify: the firmware has another key, or
        a node on the bus sends them."""
        self._half: Frame | None = None
        self._signed: tuple[int, int] | None = None

    @property
    def freshness(self) -> int:
        """The freshness value the firmware last decided (0 before a status)."""
        return self.status.freshness if self.status is not None else 0

    @property
    def signed(self) -> int | None:
        """The freshness value of the last command signed, None before one."""
        return self._signed[1] if self._signed is not None else None

    def sync(self, frame: Frame) -> Status | None:
        """Take the firmware's status from AUTH_STATUS and the AUTH_CHALLENGE
        after it, when the MAC verifies; any other frame changes nothing.

        :returns: the status adopted, or None.
        """
        if frame.name == "AUTH_STATUS":
            self._half = frame
            return None
        if frame.name != "AUTH_CHALLENGE":
            return None
        half, self._half = self._half, None
        if half is None:
            self.forged += 1  # a second half without its first
            return None
        status = Status(
            session=int(half.signals["session"]),
            freshness=int(frame.signals["freshness"]),
            last=int(half.signals["last"]),
            refused=int(half.signals["refused"]),
            saturated=bool(half.signals["refused_saturated"]),
        )
        got = int(frame.signals["mac"]).to_bytes(MAC_LEN, "little")
        if not hmac.compare_digest(status_mac(self.key, status), got):
            self.forged += 1
            return None
        self.status = status
        return status

    def can_sign(self) -> bool:
        """Whether there is a challenge this sender has not signed yet."""
        st = self.status
        return (
            st is not None
            and st.freshness < FV_MAX
            and self._signed != (st.session, st.freshness + 1)
        )

    def param_set(self, proto: Protocol, index: int, value: float) -> list[can.Message]:
        """PARAM_SET of @p index = @p value and its PARAM_AUTH, signed for the
        firmware's challenge.

        :raises AuthKeyError: no status verified yet, this challenge was
            signed already (a new status must come first), or the session is
            spent (the firmware draws a new one).
        """
        st = self.status
        if st is None:
            raise AuthKeyError(
                "no authenticated status from the firmware yet: ask for one (PARAM_GET)"
            )
        if st.freshness >= FV_MAX:
            raise AuthKeyError("the firmware's session is spent: wait for its next status")
        fv = st.freshness + 1
        if self._signed == (st.session, fv):
            raise AuthKeyError(
                f"challenge {fv} was signed already: wait for the firmware's next status"
            )
        pset = proto.encode("PARAM_SET", index=index, value=value)
        data = bytes(pset.data)[2:8]
        tag = cmac(
            self.key,
            mac_input(proto.data_id(pset.arbitration_id - proto.offset), data, st.session, fv),
        )
        pauth = proto.encode(
            "PARAM_AUTH",
            freshness=fv,
            mac=int.from_bytes(tag[:MAC_LEN], "little"),
            raw=True,
        )
        self._signed = (st.session, fv)
        return [pset, pauth]


STALE = 3
"""AUTH_STATUS_last of a command signed for a challenge already used up: the
one outcome a tool signs again for (once)."""
EXPIRED = 6
"""AUTH_STATUS_last of a challenge nobody used for 0.5 s, replaced at a
housekeeping: no command decided it (:func:`mstc.loop.lockstep.decides`)."""

OUTCOMES = {
    1: "another PARAM_SET came between its PARAM_SET and its PARAM_AUTH, or the "
    "PARAM_AUTH was lost (AUTH_STATUS last = missing): is another node sending commands?",
    2: "its MAC did not verify (last = mac) although the firmware's own status verifies "
    "under the same key: the command was changed on the bus (another node's PARAM_SET "
    "in between) or corrupted",
    3: "it was signed for a challenge the firmware had already used up (last = stale): "
    "another command or a refusal came first, or it arrived more than 0.5 s late",
    4: "the firmware has no key, or could draw no new session (last = no_key)",
    5: "the firmware refuses every command for 10 s after 4 failed MAC checks in a row "
    "(last = locked): a node on the bus is guessing MACs; wait, then try again",
    6: "its challenge expired before it arrived (last = expired)",
}
"""Why the firmware refused a command, by its authenticated AUTH_STATUS_last,
and what to do (docs/safety.md, "Authenticated commands")."""
