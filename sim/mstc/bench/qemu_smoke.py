# SPDX-License-Identifier: MIT
"""Run a board image under QEMU and check that its control loop runs
(``make firmware-smoke``).

Usage: python -m mstc.bench.qemu_smoke [--seconds S] [--min-steps N] IMAGE_DIR...

IMAGE_DIR is build/firmware/<board> (mstc.elf), the bxCAN image. The image is
the real one, unchanged: the same bytes that `make flash` writes. QEMU 7.2
machines (QEMU itself is driven through sim/mstc/firmware/qemu.py):

- stm32f405 on ``netduinoplus2`` (an STM32F405RG: Cortex-M4F, 1 MB flash,
  128 KB SRAM, TIM2..TIM5 emulated);
- stm32f103 on ``netduino2`` (an STM32F205RF: a Cortex-M3 like the F103,
  TIM2 at the same address with the same registers, SRAM from 0x20000000 large
  enough for the F103's 20 KB). ``stm32vldiscovery`` (STM32F100) is no use:
  8 KB of SRAM, below the image's stack, and no timers.

What QEMU lacks, and so what this does NOT test: the RCC clock tree (its
registers read as 0, so the HSE never starts and the image runs on its HSI
fallback: sysclk 16 MHz on the F4, 8 MHz on the F1), bxCAN (hal_can_open()
gets no INAK and returns -ENODEV, so no frame is sent or received), the IWDG
and the GPIO (writes ignored).

No input reaches the image (QEMU has no bxCAN), so the firmware's safety
supervisor keeps it halted, as on a board with a dead bus: not armed, state
READY, the wheels at zero. (Forcing inputs into the application's memory would
test something a board never does; docs/safety.md.)

What it does test: reset handler, .data/.bss, FPU enable (M4F), vector table,
SysTick, the control-period timer's interrupt, the main loop and its sleep,
the control tick (app_control_tick: the halt path of the supervisor) in the
image's numeric mode, the wheel speeds to PWM path, and that no fault was
taken. Checks:
- stm32_loop_stats.steps >= N (the loop ran control steps);
- the application is READY and halted because it is not armed, and both PWM
  compare registers (TIM3 CCR1/2) are 0: no motion without valid inputs;
- the CPU is not parked in the fault handler (stm32_unhandled), and the
  fault status registers CFSR and HFSR are 0;
- sysclk_hz and can_open have the values the missing emulation implies;
- the wheel loop ran on its millisecond tick, on the encoders, and reports
  the faults QEMU's timers give it (WHEEL_FAULTS below).

QEMU's STM32 timer model schedules its alarms from the wrong origin (twice
the current time), so the period it produces grows as the run goes on: the
test counts steps, not their spacing.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

from mstc.bench import ROOT
from mstc.errors import FirmwareError
from mstc.firmware.qemu import CROSS, MACHINES, BoardVm, board_of

CPU = {
    "stm32f405": ["-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16"],
    "stm32f103": ["-mcpu=cortex-m3", "-mthumb"],
}
TIM3 = 0x40000400  # same address on the F1, F2 and F4
COMM_STATE_READY = 1  # comm_state_t
COMM_HALT_NOT_ARMED = 1  # comm_halt_t
HSI_HZ = {"stm32f405": 16_000_000, "stm32f103": 8_000_000}
ENODEV = 19
CFSR, HFSR = 0xE000ED28, 0xE000ED2C
# The wheel loop under QEMU (hal/stm32/encoder.c, docs/wheel.md): QEMU models
# TIM2..TIM5 as counters of its own clock, whatever their mode, and not TIM1.
# TIM4 and TIM5 then count far more a millisecond than a wheel can turn: the
# loop's implausible-encoder fault (WHL_FAULT_ENCODER_*), motors stopped. The
# F103's TIM1 reads 0: a wheel standing still, no fault while nothing drives it.
WHEEL_FAULTS = {"stm32f405": 0x4 | 0x8, "stm32f103": 0x4}


def app_offsets(board: str, numeric: str) -> dict[str, int]:
    """Offsets in app_t, from the cross compiler itself (same flags)."""
    fields = ["state", "halt", "steps"]
    src = (
        '#include <stddef.h>\n#include "app/app.h"\nconst unsigned mstc_offsets[] = {'
        + ", ".join(f"offsetof(app_t, {f})" for f in fields)
        + "};\n"
    )
    flags = ["-DNUM_FIXED"] if numeric == "fixed" else []
    out = subprocess.run(
        [
            CROSS + "gcc",
            "-std=c11",
            *CPU[board],
            *flags,
            f"-I{ROOT}/firmware",
            f"-I{ROOT}/hal/include",
            "-x",
            "c",
            "-S",
            "-o",
            "-",
            "-",
        ],
        input=src,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    words = [int(w) for w in re.findall(r"^\s*\.word\s+(\d+)", out, re.M)]
    return dict(zip(fields, words, strict=True))


def smoke(image_dir: Path, seconds: float, min_steps: int) -> bool:
    board = board_of(image_dir)
    if board not in MACHINES:
        print(f"{image_dir.name}: no QEMU machine for this board")
        return False
    numeric = (image_dir / "numeric.txt").read_text().strip()
    off = app_offsets(board, numeric)
    try:
        vm = BoardVm(image_dir)
    except FirmwareError as exc:
        print(f"{image_dir.name}: FAILED: {exc}")
        return False
    with vm:
        mon = vm.monitor
        fault = vm.syms["stm32_unhandled"]
        app = vm.address("app")
        time.sleep(seconds)
        mon.cmd("stop")
        st = vm.stats()
        cfsr, hfsr = mon.words(CFSR, 2)
        state = mon.byte_at(app + off["state"])
        halt = mon.byte_at(app + off["halt"])
        ccr1, ccr2 = mon.words(TIM3 + 0x34, 2)
        wheel = vm.wheel_stats()
        periods, closed_loop, wheel_faults = wheel.periods, wheel.closed_loop, wheel.faults
        regs = mon.cmd("info registers")
        m = re.search(r"R15=([0-9a-f]{8})", regs)
        pc = int(m.group(1), 16) if m else -1
    checks = [
        (st.steps >= min_steps, f"control steps {st.steps} (>= {min_steps})"),
        (
            not (fault[0] <= pc < fault[0] + max(fault[1], 2)),
            f"pc 0x{pc:08x} not in stm32_unhandled",
        ),
        (cfsr == 0 and hfsr == 0, f"CFSR 0x{cfsr:08x}, HFSR 0x{hfsr:08x} (no fault taken)"),
        (state == COMM_STATE_READY, f"application state {state} (1: READY)"),
        (halt == COMM_HALT_NOT_ARMED, f"halt reason {halt} (1: not armed)"),
        (ccr1 == ccr2 == 0, f"PWM compare {ccr1}, {ccr2} (both 0: no motion without inputs)"),
        (
            periods >= 10 * st.steps and closed_loop,
            f"wheel periods {periods} (>= 10 per control step), on the encoders",
        ),
        (
            wheel_faults == WHEEL_FAULTS[board],
            f"wheel faults 0x{wheel_faults:x} (0x{WHEEL_FAULTS[board]:x}: what QEMU's timers give)",
        ),
        (
            st.sysclk_hz == HSI_HZ[board],
            f"sysclk {st.sysclk_hz} Hz (HSI fallback: QEMU has no RCC)",
        ),
        (
            st.can_open == -ENODEV,
            f"hal_can_open() = {st.can_open} (-ENODEV: QEMU has no bxCAN)",
        ),
    ]
    ok = all(c for c, _ in checks)
    print(
        f"{image_dir.name} on qemu-system-arm -M {MACHINES[board]} ({seconds:g} s): "
        f"{'ok' if ok else 'FAILED'}; overruns {st.overruns}, reset cause {st.reset_cause}"
    )
    for c, text in checks:
        print(f"  {'ok  ' if c else 'FAIL'} {text}")
    return ok


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m mstc.bench.qemu_smoke", description=__doc__.split("\n\n")[0]
    )
    ap.add_argument("--seconds", type=float, default=2.0, help="run time before the checks")
    ap.add_argument("--min-steps", type=int, default=10)
    ap.add_argument("image_dir", nargs="+", type=Path)
    args = ap.parse_args(argv)
    if shutil.which("qemu-system-arm") is None:
        print("qemu-system-arm is missing (Debian: qemu-system-arm)")
        return 1
    ok = True
    for d in args.image_dir:
        ok = smoke(d, args.seconds, args.min_steps) and ok
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
