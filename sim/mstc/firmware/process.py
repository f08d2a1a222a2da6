# SPDX-License-Identifier: MIT
"""The firmware as its own process: ``mstc-fw`` (``make fw``, ``hal/linux``) on a
SocketCAN bus, started afresh for a run and stopped after it, like a board
reset (``mstc hil --fw``, docs/hil.md)."""

from __future__ import annotations

import select
import subprocess
from collections.abc import Sequence
from pathlib import Path

from mstc.errors import FirmwareError


def start_firmware(
    exe: Path,
    channel: str,
    key_file: Path | None = None,
    timeout: float = 30.0,
    *,
    period_ms: int | None = None,
    prefix: Sequence[str] = (),
) -> subprocess.Popen[str]:
    """Start ``exe --can channel [--key-file key_file]`` (with ``--realtime
    --period-ms`` when @p period_ms is given) and wait until it is on the bus
    (its first line on stderr says so). Without @p key_file it takes its key
    from the environment, as the tools do. @p prefix goes in front of the
    command: the vcan VM's runner (:meth:`mstc.can.vmbridge.Bridge.runner`)
    starts it in the VM.

    :raises FirmwareError: it exited or said nothing in @p timeout seconds.
    """
    if not exe.is_file():
        raise FirmwareError(f"--fw {exe}: no such file (make fw builds build/host/mstc-fw)")
    cmd = [str(exe), "--can", channel]
    if key_file is not None:
        cmd += ["--key-file", str(key_file)]
    if period_ms is not None:
        cmd += ["--realtime", "--period-ms", str(period_ms)]
    proc = subprocess.Popen(
        [*prefix, *cmd], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True
    )
    assert proc.stderr is not None
    ready, _, _ = select.select([proc.stderr], [], [], timeout)
    line = proc.stderr.readline() if ready else ""
    if " mode on " not in line:
        proc.kill()
        said = (line + proc.stderr.read()).strip() or "no answer"
        raise FirmwareError(f"{exe} did not start on {channel}: {said}")
    return proc


def stop_firmware(proc: subprocess.Popen[str]) -> None:
    """Stop a firmware process started by :func:`start_firmware`."""
    proc.terminate()
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
