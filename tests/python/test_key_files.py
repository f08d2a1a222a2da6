# SPDX-License-Identifier: MIT
"""Issue 21, case 5: the device key in world-readable build outputs.

Every file `make firmware` leaves that holds the key (its 16 bytes, or its
hex digits) must be readable by its owner only, as the key file is; a key
file others can read is warned about.
"""

from __future__ import annotations

import os
import stat
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}


def _key(path: Path) -> bytes:
    digits = "".join(
        line.strip() for line in path.read_text().splitlines() if not line.startswith("#")
    )
    return bytes.fromhex(digits)


def _contents(path: Path) -> bytes:
    """The bytes of @p path; of an Intel HEX file, the data its records carry
    (the key may straddle two records)."""
    raw = path.read_bytes()
    if path.suffix != ".hex":
        return raw
    data = bytearray()
    for line in raw.decode(errors="replace").splitlines():
        if line.startswith(":") and len(line) >= 11 and line[7:9] == "00":
            data += bytes.fromhex(line[9 : 9 + 2 * int(line[1:3], 16)])
    return bytes(data)


def test_every_build_output_that_holds_the_key_is_private() -> None:
    r = subprocess.run(
        ["make", "--no-print-directory", "firmware", "BOARD=stm32f103"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=_env(),
    )
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]
    key = _key(ROOT / "keys" / "device.key")
    needles = (key, key.hex().encode(), ", ".join(f"0x{b:02x}" for b in key).encode())
    holders = []
    for top in (ROOT / "build" / "firmware" / "stm32f103", ROOT / "build" / "key"):
        for path in top.rglob("*"):
            if path.is_file() and any(n in _contents(path) for n in needles):
                holders.append(path)
    exposed = [
        f"{p.relative_to(ROOT)} ({stat.filemode(p.stat().st_mode)})"
        for p in holders
        if p.stat().st_mode & 0o077
    ]
    assert not exposed, "the key is in files others can read: " + ", ".join(exposed)


def test_a_key_file_others_can_read_is_warned_about(tmp_path: Path) -> None:
    key = tmp_path / "device.key"
    key.write_text("000102030405060708090a0b0c0d0e0f\n")
    key.chmod(0o644)
    r = subprocess.run(
        [str(ROOT / "tools" / "setup" / "device-key"), str(key), "--bin", str(tmp_path / "k.bin")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    assert "warning" in r.stderr and str(key) in r.stderr, r.stderr
