# SPDX-License-Identifier: MIT
"""The board images (mk/firmware.mk): both build with the cross compiler and
warnings as errors, fit the budgets (flash <= 64 KiB, RAM <= 16 KiB, worst-case
stack within its reservation), the blank port links, and both images run
their control loop and their wheel loop under QEMU (mstc.bench.qemu_smoke
says what that covers and what QEMU cannot: no RCC, no bxCAN, no encoder
mode).

Needs the cross toolchain and qemu-system-arm (tools/setup/debian-test.txt)
and PyPI for the vendor SVD files (tools/svd/fetch): without them these fail,
loudly."""

import os
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _env() -> dict[str, str]:
    """The environment without a parent make's flags (under `make test`,
    MAKEFLAGS carries its command-line variables into this make)."""
    return {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}


def make(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        ["make", "--no-print-directory", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
        env=_env(),
    )


def test_board_images_build_and_fit_their_budgets() -> None:
    r = make("firmware-all")
    out = r.stdout + r.stderr
    assert r.returncode == 0, out[-4000:]
    for board in ("stm32f405", "stm32f103", "template"):
        d = ROOT / "build" / "firmware" / board
        for name in ("mstc.elf", "mstc.bin", "mstc.hex", "size.txt"):
            assert (d / name).is_file(), f"{board}: {name} missing"
    # The budget report ran and every line of it passed.
    assert "stm32f405 (float)" in out and "stm32f103 (fixed)" in out
    assert "OVER" not in out


def test_board_images_run_their_control_loop_under_qemu() -> None:
    r = make("firmware-smoke")
    assert r.returncode == 0, (r.stdout + r.stderr)[-4000:]
    assert r.stdout.count(": ok;") == 2, r.stdout
    assert r.stdout.count("ok   PWM compare") == 2, r.stdout
    assert r.stdout.count("ok   wheel faults") == 2, r.stdout
