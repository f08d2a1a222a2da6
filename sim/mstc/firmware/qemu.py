# SPDX-License-Identifier: MIT
"""The board images under QEMU: boot one, reach its serial line and its memory.

Everything mstc does with ``qemu-system-arm`` goes through here: the smoke
test of the images (mstc.bench.qemu_smoke) and processor-in-the-loop runs
(``mstc hil --qemu``, docs/hil.md), which drive the slcan image
(``make firmware CAN=slcan``) through python-can's ``slcan`` interface.

QEMU 7.2 machines (what they emulate and what not: mstc.bench.qemu_smoke):

- stm32f405 on ``netduinoplus2`` (STM32F405RG, Cortex-M4F; core clock as QEMU
  models it: 168 MHz);
- stm32f103 on ``netduino2`` (STM32F205RF, a Cortex-M3 with TIM2 and USART2 at
  the F1's addresses; 120 MHz).

Both place USART2 (0x40004400) on the second ``-serial`` (the first is USART1),
so ``-serial null -serial tcp:...`` puts the slcan line on a local TCP port,
which pyserial opens as ``socket://127.0.0.1:PORT``. The port is QEMU's choice
(port 0), read back from the monitor.

``-icount shift=0`` makes the emulated CPU execute one instruction per
nanosecond of virtual time, deterministically, and SysTick count the virtual
core clock: a difference of SysTick counts (``stm32_time_cycles()``) is thus
counts × 10⁹ / f_core instructions, with f_core the clock QEMU gives the core
(:meth:`BoardVm.core_hz`). Idle time (the core sleeping in WFI) still passes
at the host's pace, so timers stay timers: only the instruction counts are
exact.
"""

from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType

from mstc.errors import FirmwareError

CROSS = os.environ.get("CROSS_COMPILE", "arm-none-eabi-")
MACHINES = {"stm32f405": "netduinoplus2", "stm32f103": "netduino2"}
"""The QEMU machine of each board."""
ICOUNT = "shift=0"
"""``-icount``: one instruction per nanosecond of virtual time."""


def board_of(image_dir: Path) -> str:
    """The board of an image directory: ``build/firmware/<board>[-<can>]``."""
    return image_dir.name.split("-")[0]


def symbols(elf: Path) -> dict[str, tuple[int, int]]:
    """Address and size of every sized symbol of @p elf (``nm -S``)."""
    out = subprocess.run(
        [CROSS + "nm", "-S", str(elf)], check=True, capture_output=True, text=True
    ).stdout
    syms = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 4:
            syms[parts[3]] = (int(parts[0], 16), int(parts[1], 16))
    return syms


class Monitor:
    """QEMU's human monitor on a Unix socket: commands and memory reads."""

    def __init__(self, path: str, timeout: float = 5.0):
        self.timeout = timeout
        self.s = socket.socket(socket.AF_UNIX)
        for _ in range(100):
            try:
                self.s.connect(path)
                break
            except OSError:
                time.sleep(0.05)
        else:
            raise FirmwareError("the QEMU monitor socket did not come up")
        self._read()

    def _read(self) -> str:
        data = b""
        self.s.settimeout(self.timeout)
        while not data.endswith(b"(qemu) "):
            chunk = self.s.recv(65536)
            if not chunk:
                break
            data += chunk
        return data.decode(errors="replace")

    def cmd(self, text: str) -> str:
        """Run one monitor command; its output."""
        self.s.sendall((text + "\n").encode())
        return self._read()

    def words(self, addr: int, n: int) -> list[int]:
        """@p n 32-bit words of the target's memory from @p addr."""
        out = self.cmd(f"xp /{n}wx 0x{addr:08x}")
        vals = []
        for line in out.splitlines():
            m = re.match(r"^\s*[0-9a-f]+:\s+(.*)$", line.strip())
            if m:
                vals += [int(v, 16) for v in m.group(1).split()]
        return vals[:n]

    def byte_at(self, addr: int) -> int:
        """One byte of the target's memory, through word reads."""
        return (self.words(addr - addr % 4, 1)[0] >> (8 * (addr % 4))) & 0xFF

    def close(self) -> None:
        self.s.close()


LOOP_STATS_WORDS = 11
"""Words of stm32_loop_stats_t (hal/stm32/stm32_hal.h) before its sequence word."""
LOOP_STATS_SEQ = 4 * LOOP_STATS_WORDS
"""Offset of the sequence word ``seq``, the struct's last [bytes]."""


@dataclass(frozen=True)
class LoopStats:
    """stm32_loop_stats of the board's main loop (hal/stm32/stm32_hal.h)."""

    steps: int
    overruns: int
    can_open: int
    reset_cause: int
    sysclk_hz: int
    lockstep: bool
    frame_steps: int
    step_cycles_min: int
    step_cycles_max: int
    step_cycles_sum: int

    @classmethod
    def from_words(cls, w: list[int]) -> LoopStats:
        if len(w) != LOOP_STATS_WORDS:
            raise FirmwareError(f"read {len(w)} words of stm32_loop_stats, not {LOOP_STATS_WORDS}")
        can_open = w[2] - (1 << 32) if w[2] >= 1 << 31 else w[2]
        return cls(
            steps=w[0],
            overruns=w[1],
            can_open=can_open,
            reset_cause=w[3],
            sysclk_hz=w[4],
            lockstep=bool(w[5]),
            frame_steps=w[6],
            step_cycles_min=w[7],
            step_cycles_max=w[8],
            step_cycles_sum=w[9] | (w[10] << 32),
        )

    @classmethod
    def read(
        cls, words: Callable[[int, int], list[int]], addr: int, timeout: float = 2.0
    ) -> LoopStats:
        """One consistent copy of the statistics at @p addr, read through
        @p words (address, count → 32-bit words) while the board runs.

        The board's main loop makes the sequence word odd before it changes
        any other word and even again after the last (a seqlock,
        hal/stm32/stm32_hal.h). Each call of @p words is a separate monitor
        command, done before the next begins, so reading ``seq``, then the
        words, then ``seq`` again orders the three reads; within one command
        the order of the words is QEMU's (a memcpy), hence ``seq`` alone. If
        both readings of ``seq`` are the same even number, no update was under
        way while the words were read, nor began before the second reading:
        the copy is one the board held at some moment. Otherwise read again.

        :raises FirmwareError: no consistent copy within @p timeout [s].
        """
        deadline = time.monotonic() + timeout
        seq = words(addr + LOOP_STATS_SEQ, 1)[0]
        while True:
            w = words(addr, LOOP_STATS_WORDS)
            after = words(addr + LOOP_STATS_SEQ, 1)[0]
            if after == seq and seq % 2 == 0:
                return cls.from_words(w)
            if time.monotonic() > deadline:
                raise FirmwareError(
                    f"stm32_loop_stats kept changing for {timeout} s (sequence word {after})"
                )
            seq = after

    @property
    def measured_steps(self) -> int:
        """Steps the cycle statistics cover: those of the mode in force."""
        return self.frame_steps if self.lockstep else self.steps


WHEEL_STATS_WORDS = 11
"""Words of stm32_wheel_stats_t (hal/stm32/stm32_hal.h)."""


@dataclass(frozen=True)
class WheelStats:
    """stm32_wheel_stats of the board's wheel loop (hal/stm32/stm32_hal.h):
    written by the main loop with no sequence word, so read it while the
    loop is still (after a run, or for the smoke test's coarse checks)."""

    periods: int
    overruns: int
    closed_loop: bool
    faults: int
    speed: tuple[float, float]
    """Measured at the last period [rad/s]."""
    cycles_max: int
    """The longest period's, the firmware's (a simulated motor's not)."""
    cycles_sum: int
    step_periods: int
    """Periods run on the plant's time (a PIL image in lock-step)."""

    @classmethod
    def from_words(cls, w: list[int]) -> WheelStats:
        if len(w) != WHEEL_STATS_WORDS:
            raise FirmwareError(
                f"read {len(w)} words of stm32_wheel_stats, not {WHEEL_STATS_WORDS}"
            )

        def signed(x: int) -> int:
            return x - (1 << 32) if x >= 1 << 31 else x

        return cls(
            periods=w[0],
            overruns=w[1],
            closed_loop=bool(w[2]),
            faults=w[3],
            speed=(signed(w[4]) / 1000.0, signed(w[5]) / 1000.0),
            cycles_max=w[6],
            cycles_sum=w[7] | (w[8] << 32),
            step_periods=w[9],
        )


PIL_TRACE_N = 1000
"""Periods stm32_pil_trace holds (STM32_PIL_TRACE_N, hal/stm32/stm32_hal.h)."""
PIL_TRACE_SCALE = 512.0
"""Its counts per rad/s (STM32_PIL_TRACE_SCALE)."""


class BoardVm:
    """A board image running under ``qemu-system-arm``, until :meth:`stop`.

    :param image_dir: ``build/firmware/<board>[-<can>]``, holding mstc.elf.
    :param serial: put USART2 on a local TCP port (:attr:`channel`).
    :param boot_timeout: how long the main loop may take to start [s].
    :raises FirmwareError: no such image or machine, QEMU missing, or the image
        does not start its main loop.
    """

    def __init__(self, image_dir: Path, *, serial: bool = False, boot_timeout: float = 30.0):
        self.image_dir = image_dir
        self.board = board_of(image_dir)
        self.elf = image_dir / "mstc.elf"
        if self.board not in MACHINES:
            raise FirmwareError(f"{image_dir}: no QEMU machine for board {self.board!r}")
        if not self.elf.is_file():
            raise FirmwareError(f"{self.elf} missing: make firmware BOARD={self.board}")
        if shutil.which("qemu-system-arm") is None:
            raise FirmwareError("qemu-system-arm is missing (Debian: qemu-system-arm)")
        self.machine = MACHINES[self.board]
        self.syms = symbols(self.elf)
        self._tmp = tempfile.mkdtemp(prefix="mstc-qemu-")
        sock = os.path.join(self._tmp, "monitor.sock")
        serials = ["-serial", "null", "-serial", "tcp:127.0.0.1:0,server=on,wait=off,nodelay=on"]
        cmd = [
            "qemu-system-arm",
            "-M",
            self.machine,
            "-kernel",
            str(self.elf),
            "-nographic",
            *(serials if serial else ["-serial", "none"]),
            "-icount",
            ICOUNT,
            "-monitor",
            f"unix:{sock},server,nowait",
        ]
        self.proc = subprocess.Popen(
            cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
        )
        try:
            self.monitor = Monitor(sock)
            self.channel = self._serial_url() if serial else ""
            """pyserial URL of USART2 (``socket://127.0.0.1:PORT``); empty without serial."""
            self._wait_booted(boot_timeout)
        except BaseException:
            self.stop()
            raise

    def _serial_url(self) -> str:
        out = self.monitor.cmd("info chardev")
        m = re.search(r"serial1: filename=\S*tcp:127\.0\.0\.1:(\d+)", out)
        if m is None:
            raise FirmwareError(f"QEMU did not say where USART2 listens: {out.strip()!r}")
        return f"socket://127.0.0.1:{m.group(1)}"

    def _wait_booted(self, timeout: float) -> None:
        """Until the main loop has run a step: start-up done, the CAN
        transport open (hal_can_open() comes first)."""
        deadline = time.monotonic() + timeout
        while self.stats().steps == 0:
            if self.proc.poll() is not None:
                raise FirmwareError(f"QEMU exited: {self._stderr()}")
            if time.monotonic() > deadline:
                raise FirmwareError(f"{self.elf} ran no control step in {timeout} s under QEMU")
            time.sleep(0.02)

    def _stderr(self) -> str:
        assert self.proc.stderr is not None
        return self.proc.stderr.read().decode(errors="replace").strip() or "no message"

    def address(self, name: str) -> int:
        """Address of symbol @p name in the image."""
        try:
            return self.syms[name][0]
        except KeyError:
            raise FirmwareError(f"{self.elf} has no symbol {name}") from None

    def stats(self) -> LoopStats:
        """stm32_loop_stats now: a consistent copy (:meth:`LoopStats.read`)."""
        return LoopStats.read(self.monitor.words, self.address("stm32_loop_stats"))

    def wheel_stats(self) -> WheelStats:
        """stm32_wheel_stats now (:class:`WheelStats` says when to read it)."""
        return WheelStats.from_words(
            self.monitor.words(self.address("stm32_wheel_stats"), WHEEL_STATS_WORDS)
        )

    def pil_trace(self) -> list[tuple[float, float]]:
        """A PIL image's stm32_pil_trace (hal/stm32/pil_wheels.c): each
        wheel's true speed after each of its first periods on the plant's
        time [rad/s].

        :raises FirmwareError: not a PIL image (build/firmware/<board>-pil).
        """
        addr = self.address("stm32_pil_trace")
        n = min(self.monitor.words(addr, 1)[0], PIL_TRACE_N)
        words = self.monitor.words(addr + 4, n) if n else []
        out = []
        for w in words:  # one period: left in the low half, right in the high
            left, right = w & 0xFFFF, w >> 16
            out.append(
                (
                    (left - 0x10000 if left >= 0x8000 else left) / PIL_TRACE_SCALE,
                    (right - 0x10000 if right >= 0x8000 else right) / PIL_TRACE_SCALE,
                )
            )
        return out

    def core_hz(self) -> int:
        """The core clock QEMU models for this machine [Hz] (SysTick's
        processor clock), from ``info qtree``."""
        out = self.monitor.cmd("info qtree")
        m = re.search(r'clock-in "cpuclk" freq_hz=([\d.]+) ?([kMG]?)Hz', out)
        if m is None:
            raise FirmwareError("QEMU did not say the core clock (info qtree)")
        scale = {"": 1, "k": 10**3, "M": 10**6, "G": 10**9}[m.group(2)]
        return round(float(m.group(1)) * scale)

    def stop(self) -> None:
        """Quit QEMU (killed if it does not) and remove its socket directory."""
        monitor = getattr(self, "monitor", None)
        try:
            if monitor is not None and self.proc.poll() is None:
                try:
                    monitor.cmd("quit")
                except OSError:
                    pass
                monitor.close()
            else:
                self.proc.terminate()
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        finally:
            shutil.rmtree(self._tmp, ignore_errors=True)

    def __enter__(self) -> BoardVm:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()
