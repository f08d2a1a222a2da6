# SPDX-License-Identifier: MIT
"""`make flash` and tools/flash build the right command (no probe is attached
here, so the command is checked, not run: --dry-run / FLASH_DRY_RUN=1)."""

import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _env() -> dict[str, str]:
    """The environment without a parent make's flags (under `make test`,
    MAKEFLAGS carries its command-line variables into this make)."""
    return {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}


FLASH = ROOT / "tools" / "flash"


def flash(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(FLASH), *args], cwd=ROOT, capture_output=True, text=True, check=False
    )


ELF = {b: ROOT / "build" / "firmware" / b / "mstc.elf" for b in ("stm32f405", "stm32f103")}


@pytest.mark.parametrize(
    ("board", "tool", "expected"),
    [
        (
            "stm32f405",
            "openocd",
            [
                "openocd",
                "-f",
                "interface/stlink.cfg",
                "-f",
                "target/stm32f4x.cfg",
                "-c",
                f"program {{{ELF['stm32f405']}}} verify reset exit",
            ],
        ),
        (
            "stm32f103",
            "openocd",
            [
                "openocd",
                "-f",
                "interface/stlink.cfg",
                "-f",
                "target/stm32f1x.cfg",
                "-c",
                f"program {{{ELF['stm32f103']}}} verify reset exit",
            ],
        ),
        (
            "stm32f405",
            "st-flash",
            [
                "st-flash",
                "--reset",
                "write",
                str(ELF["stm32f405"].with_suffix(".bin")),
                "0x08000000",
            ],
        ),
        (
            "stm32f103",
            "st-flash",
            [
                "st-flash",
                "--reset",
                "write",
                str(ELF["stm32f103"].with_suffix(".bin")),
                "0x08000000",
            ],
        ),
        (
            "stm32f405",
            "pyocd",
            ["pyocd", "flash", "--target", "stm32f405rg", str(ELF["stm32f405"])],
        ),
        (
            "stm32f103",
            "pyocd",
            ["pyocd", "flash", "--target", "stm32f103c8", str(ELF["stm32f103"])],
        ),
    ],
)
def test_flash_dry_run_prints_the_command(board: str, tool: str, expected: list[str]) -> None:
    r = flash("--dry-run", "--board", board, "--tool", tool, str(ELF[board]))
    assert r.returncode == 0, r.stderr
    assert shlex.split(r.stdout.strip()) == expected


def test_flash_openocd_is_the_default_and_interface_is_chosen() -> None:
    r = flash(
        "--dry-run", "--board", "stm32f405", "--interface", "cmsis-dap.cfg", str(ELF["stm32f405"])
    )
    assert r.returncode == 0, r.stderr
    cmd = shlex.split(r.stdout.strip())
    assert cmd[:5] == ["openocd", "-f", "interface/cmsis-dap.cfg", "-f", "target/stm32f4x.cfg"]


def test_flash_target_override() -> None:
    r = flash(
        "--dry-run",
        "--board",
        "stm32f103",
        "--tool",
        "pyocd",
        "--target",
        "stm32f103rc",
        str(ELF["stm32f103"]),
    )
    assert shlex.split(r.stdout.strip())[3] == "stm32f103rc"


def test_flash_path_with_spaces_stays_one_word(tmp_path: Path) -> None:
    image = tmp_path / "my dir" / "mstc.elf"
    r = flash("--dry-run", "--board", "stm32f405", str(image))
    cmd = shlex.split(r.stdout.strip())
    assert cmd[-1] == f"program {{{image}}} verify reset exit"


def test_flash_refuses_unknown_boards_and_non_elf_images() -> None:
    r = flash("--dry-run", "--board", "template", "build/firmware/template/mstc.elf")
    assert r.returncode == 2 and "no flashing for board 'template'" in r.stderr
    r = flash("--dry-run", "--board", "stm32f405", "build/firmware/stm32f405/mstc.bin")
    assert r.returncode == 2 and "expected the .elf image" in r.stderr
    r = flash("--dry-run", "--board", "stm32f405", "--tool", "jlink", "x.elf")
    assert r.returncode == 2


def test_flash_without_image_says_how_to_build_it(tmp_path: Path) -> None:
    r = flash("--board", "stm32f103", str(tmp_path / "mstc.elf"))
    assert r.returncode == 1
    assert "make firmware BOARD=stm32f103" in r.stderr


def test_make_flash_dry_run_builds_the_image_and_prints_the_command() -> None:
    """End to end through the Makefile: the image is built (cross compiler,
    warnings as errors), then the command names it. Needs the cross
    toolchain (tools/setup/debian-test.txt): without it this fails, loudly."""
    r = subprocess.run(
        [
            "make",
            "--no-print-directory",
            "flash",
            "BOARD=stm32f103",
            "FLASH_DRY_RUN=1",
            "FLASH_TOOL=st-flash",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
        env=_env(),
    )
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    last = r.stdout.strip().splitlines()[-1]
    # The image flashed is the private copy with the device key installed
    # (tools/setup/install-key), not the one in build/firmware/, which holds none.
    flashed = ROOT / "build" / "flash" / "stm32f103" / "mstc.bin"
    assert shlex.split(last) == ["st-flash", "--reset", "write", str(flashed), "0x08000000"]
    assert flashed.stat().st_mode & 0o077 == 0
    assert flashed.parent.stat().st_mode & 0o077 == 0
    assert ELF["stm32f103"].is_file()
    assert ELF["stm32f103"].with_suffix(".bin").is_file()
    assert ELF["stm32f103"].with_suffix(".hex").is_file()
