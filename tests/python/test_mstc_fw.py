# SPDX-License-Identifier: MIT
"""mstc-fw, the firmware as a Linux process (hal/linux): its command line.

The CAN exchange itself is tested over vcan by tests/python/test_hil.py.
"""

import subprocess
from pathlib import Path

import pytest


def _run(exe: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=10)


def test_help_describes_every_option(mstc_fw: Path) -> None:
    r = _run(mstc_fw, "--help")
    assert r.returncode == 0
    for option in ("--can IFACE", "--realtime", "--period-ms MS", "--help"):
        assert option in r.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((), "--can IFACE is required"),
        (("--bogus",), "unknown or incomplete option '--bogus'"),
        (("--can",), "unknown or incomplete option '--can'"),
        (("--can", "vcan0", "--period-ms", "0"), "--period-ms: expected an integer in 1..50"),
        (("--can", "vcan0", "--period-ms", "20ms"), "got '20ms'"),
    ],
)
def test_bad_command_lines_exit_2_with_one_clear_line(
    mstc_fw: Path, args: tuple[str, ...], message: str
) -> None:
    r = _run(mstc_fw, *args)
    assert r.returncode == 2
    assert message in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_a_missing_interface_is_named(mstc_fw: Path) -> None:
    r = _run(mstc_fw, "--can", "nosuchcan9")
    assert r.returncode == 1
    assert "cannot open CAN interface 'nosuchcan9'" in r.stderr
