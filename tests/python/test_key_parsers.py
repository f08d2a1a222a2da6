# SPDX-License-Identifier: MIT
"""One key-file format, read alike by everything that reads it (issue 21,
case 12): a key file with spaces between its digits was taken by ``mstc-fw``
and ``tools/setup/device-key`` and refused by the Python tools.

The format (docs/safety.md, "The key"): 32 hex digits, in either case;
blanks (spaces, tabs) and line ends anywhere are ignored; a line whose first
non-blank character is ``#`` is a comment. Each file below is labelled by
hand from that sentence, and each reader must agree with the label:
``mstc.can.secoc.read_key`` (every Python tool), ``mstc-fw --key-file``
(hal/linux/main.c), and ``tools/setup/device-key`` (the header compiled into
the board images).
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from mstc.can.secoc import read_key
from mstc.errors import AuthKeyError

ROOT = Path(__file__).resolve().parents[2]
DEVICE_KEY = ROOT / "tools" / "setup" / "device-key"
HEX = "000102030405060708090a0b0c0d0e0f"
KEY = bytes(range(16))

FILES = {
    "one line": (f"{HEX}\n", True),
    "no line end": (HEX, True),
    "a comment first": (f"# the device key\n{HEX}\n", True),
    "an indented comment": (f"   # the device key\n{HEX}\n", True),
    "spaces between the bytes": (" ".join(HEX[i : i + 2] for i in range(0, 32, 2)) + "\n", True),
    "tabs and CRLF": ("\t" + HEX[:16] + "\t" + HEX[16:] + "\r\n", True),
    "two lines": (f"{HEX[:16]}\n{HEX[16:]}\n", True),
    "upper case": (f"{HEX.upper()}\n", True),
    "a comment after the digits": (f"{HEX} # the device key\n", False),
    "31 digits": (f"{HEX[:31]}\n", False),
    "33 digits": (f"{HEX}0\n", False),
    "not hex": (f"{HEX[:31]}g\n", False),
    "a 0x prefix": (f"0x{HEX}\n", False),
    "empty": ("", False),
    "only a comment": (f"# {HEX}\n", False),
}


def _python(path: Path) -> bool:
    try:
        key = read_key(path)
    except AuthKeyError:
        return False
    assert key == KEY
    return True


def _mstc_fw(exe: Path, path: Path) -> bool:
    """Whether mstc-fw takes the key: it reads it before it opens the bus, so
    a good key gets as far as the interface, which does not exist."""
    env = {k: v for k, v in os.environ.items() if k not in ("MSTC_KEY", "MSTC_KEY_FILE")}
    r = subprocess.run(
        [str(exe), "--can", "mstcnosuch0", "--key-file", str(path)],
        capture_output=True,
        text=True,
        timeout=10,
        env=env,
    )
    refused = "expected 32 hex digits" in r.stderr
    assert refused or "cannot open CAN interface 'mstcnosuch0'" in r.stderr, r.stderr
    return not refused


def _device_key(path: Path) -> bool:
    """Whether device-key takes the key file (it checks it before it writes
    anything from it)."""
    r = subprocess.run([str(DEVICE_KEY), str(path)], capture_output=True, text=True, timeout=10)
    if r.returncode != 0:
        assert "expected 32 hex digits" in r.stderr, r.stderr
        return False
    return True


@pytest.mark.parametrize("name", list(FILES))
def test_every_reader_takes_a_key_file_alike(tmp_path: Path, mstc_fw: Path, name: str) -> None:
    text, good = FILES[name]
    path = tmp_path / "device.key"
    path.write_bytes(text.encode())
    path.chmod(0o600)
    got = {
        "mstc (Python)": _python(path),
        "mstc-fw": _mstc_fw(mstc_fw, path),
        "tools/setup/device-key": _device_key(path),
    }
    assert got == dict.fromkeys(got, good), f"{name}: {got}"
