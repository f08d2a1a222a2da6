# SPDX-License-Identifier: MIT
"""Authenticated commands, in the manner of AUTOSAR SecOC (docs/safety.md).

The tools' side of ``firmware/auth``: every PARAM_SET (parameters and the arm
command) is followed by a PARAM_AUTH frame carrying the low 20 bits of a
32-bit freshness value and the first 4 bytes of

    AES-128-CMAC(key, data_id[2] || PARAM_SET bytes 2..7 || freshness[4])

with the data ID (PARAM_SET's ``E2EDataID``, 0x1120) and the freshness value
big-endian. The firmware accepts each freshness value once, in increasing
order, and publishes the last one it accepted in AUTH_STATUS; a tool starts
from there (:meth:`Authenticator.sync`).

CMAC is ``cryptography``'s. The key is 16 bytes, per device, never committed:
:func:`load_key` finds it (an explicit file, ``$MSTC_KEY``, ``$MSTC_KEY_FILE``,
then ``keys/device.key``, which ``make key`` generates).
``tests/data/test.key`` is a published test key (RFC 4493's example key) for
the tests and the committed logs: never flash it.
"""

from __future__ import annotations

import os
import re
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
"""Bytes of the CMAC that PARAM_AUTH carries."""
FV_LOW_BITS = 20
"""Bits of the freshness value that PARAM_AUTH carries."""
FV_MAX = (1 << 32) - 1
"""The freshness value is 32 bits; after this one the key must change."""
KEY_ENV = "MSTC_KEY"
"""Environment variable holding a key as 32 hex digits."""
KEY_FILE_ENV = "MSTC_KEY_FILE"
"""Environment variable naming a key file."""
DEFAULT_KEY_FILE = ROOT / "keys" / "device.key"
"""The device key `make key` generates (git-ignored)."""
TEST_KEY_FILE = ROOT / "tests" / "data" / "test.key"
"""The published test key of the tests and the committed logs."""


def parse_key(text: str, source: str) -> bytes:
    """The key in @p text: 32 hex digits; lines starting with ``#`` are comments.

    :raises AuthKeyError: anything else, naming @p source.
    """
    digits = "".join(
        line.strip() for line in text.splitlines() if not line.lstrip().startswith("#")
    )
    if not re.fullmatch(r"[0-9a-fA-F]{32}", digits):
        raise AuthKeyError(
            f"{source}: expected 32 hex digits (an AES-128 key), got {len(digits)} characters"
        )
    return bytes.fromhex(digits)


def read_key(path: Path) -> bytes:
    """The key in file @p path (see :func:`parse_key`)."""
    try:
        text = path.read_text()
    except OSError as exc:
        raise AuthKeyError(f"cannot read key file {path}: {exc.strerror}") from exc
    return parse_key(text, str(path))


def key_file(path: Path | None = None) -> Path | None:
    """The file :func:`load_key` takes the key from, None when it takes it
    from ``$MSTC_KEY``."""
    if path is not None:
        return path
    if os.environ.get(KEY_ENV):
        return None
    if os.environ.get(KEY_FILE_ENV):
        return Path(os.environ[KEY_FILE_ENV])
    return DEFAULT_KEY_FILE


def load_key(path: Path | None = None) -> bytes:
    """The key to use: @p path if given, else ``$MSTC_KEY`` (hex), else the
    file ``$MSTC_KEY_FILE``, else ``keys/device.key``.

    :raises AuthKeyError: none found, or not a key.
    """
    source = key_file(path)
    if source is None:
        return parse_key(os.environ[KEY_ENV], f"${KEY_ENV}")
    if source == DEFAULT_KEY_FILE and not source.is_file():
        raise AuthKeyError(
            f"no key: {DEFAULT_KEY_FILE} does not exist (`make key` generates it), "
            f"and neither {KEY_ENV} nor {KEY_FILE_ENV} is set (docs/safety.md, 'The key')"
        )
    return read_key(source)


def cmac(key: bytes, data: bytes) -> bytes:
    """AES-128-CMAC (RFC 4493) of @p data under @p key: 16 bytes."""
    c = CMAC(algorithms.AES(key))
    c.update(data)
    return c.finalize()


def mac_input(data_id: int, data: bytes, freshness: int) -> bytes:
    """SecOC's DataToAuthenticator: data ID, the 6 authenticated bytes, freshness."""
    return data_id.to_bytes(2, "big") + bytes(data) + freshness.to_bytes(4, "big")


class Authenticator:
    """A sender of authenticated commands.

    :param key: the firmware's key.
    :param freshness: the last freshness value used (the next command carries
        one more); :meth:`sync` moves it to the firmware's.
    """

    def __init__(self, key: bytes, freshness: int = 0) -> None:
        if len(key) != KEY_LEN:
            raise AuthKeyError(f"a key is {KEY_LEN} bytes, not {len(key)}")
        self.key = key
        self.freshness = freshness

    def sync(self, frame: Frame) -> None:
        """Take the freshness of an AUTH_STATUS frame when it is ahead of ours."""
        if frame.name == "AUTH_STATUS":
            self.freshness = max(self.freshness, int(frame.signals["freshness"]))

    def param_set(self, proto: Protocol, index: int, value: float) -> list[can.Message]:
        """PARAM_SET of @p index = @p value and its PARAM_AUTH, with the next
        freshness value."""
        if self.freshness >= FV_MAX:
            raise AuthKeyError("the freshness value is spent: give the device a new key")
        self.freshness += 1
        pset = proto.encode("PARAM_SET", index=index, value=value)
        data = bytes(pset.data)[2:8]
        tag = cmac(self.key, mac_input(proto.data_id(pset.arbitration_id), data, self.freshness))
        pauth = proto.encode(
            "PARAM_AUTH",
            freshness=self.freshness & ((1 << FV_LOW_BITS) - 1),
            mac=int.from_bytes(tag[:MAC_LEN], "little"),
            raw=True,
        )
        return [pset, pauth]
