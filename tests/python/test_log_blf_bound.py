# SPDX-License-Identifier: MIT
"""BLF logs cannot exhaust memory (issue 30, L1): a container is inflated a
piece at a time up to a bound (mstc.logs.blf.MAX_CONTAINER_BYTES), and the
whole log up to another (MAX_LOG_BYTES); beyond either the read stops with
one error naming the file, the container and its byte offset.

The bombs are built by hand: a BLF file python-can writes from a committed
log, then one LOG_CONTAINER object (Vector's layout, as python-can's reader
and writer read and write it: "LOBJ", header size 16, version 1, object size,
type 10; method 2 (zlib), uncompressed size) whose zlib stream inflates to
256 MiB of well-formed objects of a type no reader uses (each 4 kB: the
base header, a version 1 header, zeros; readers skip them), from about
260 kB. Its offset is the size of the file before it. Memory is
Python's own allocations (tracemalloc), which hold every byte zlib inflates.
"""

from __future__ import annotations

import struct
import subprocess
import sys
import tracemalloc
import zlib
from pathlib import Path

import can
import pytest

from logfiles import DATA
from mstc.errors import LogError
from mstc.logs import blf
from mstc.logs.read import read_log

BOMB_BYTES = 256 << 20
"""What the bomb inflates to [bytes]."""
PEAK_LIMIT = 64 << 20
"""Python's allocations while reading it must stay below this [bytes]: four
times the container bound the docs give (16 MiB)."""


def blf_of(log: Path, out: Path) -> int:
    """@p log written as BLF by python-can into @p out; its size [bytes]."""
    with can.Logger(str(out)) as writer:
        for msg in can.LogReader(str(log)):
            writer.on_message_received(msg)
    return out.stat().st_size


def container(data: bytes, uncompressed: int) -> bytes:
    """A LOG_CONTAINER object holding zlib data @p data, padded to 4 bytes."""
    body = struct.pack("<H6xL4x", 2, uncompressed) + data
    obj = struct.pack("<4sHHLL", b"LOBJ", 16, 1, 16 + len(body), 10) + body
    return obj + bytes(len(obj) % 4)


OBJECT_BYTES = 4096
UNUSED_OBJECT = (
    struct.pack("<4sHHLL", b"LOBJ", 32, 1, OBJECT_BYTES, 9999)
    + struct.pack("<LHHQ", 1, 0, 0, 0)
    + bytes(OBJECT_BYTES - 32)
)
"""A well-formed BLF object of type 9999, which no reader uses: skipped."""


def inflating_to(n: int) -> bytes:
    """zlib of @p n bytes of :data:`UNUSED_OBJECT`, a piece at a time."""
    z = zlib.compressobj(9)
    piece = UNUSED_OBJECT * ((1 << 20) // len(UNUSED_OBJECT))
    out = [z.compress(piece) for _ in range(n // len(piece))]
    return b"".join([*out, z.flush()])


def test_a_blf_zlib_bomb_is_refused_naming_its_container_and_offset(
    tmp_path: Path, db: object
) -> None:
    path = tmp_path / "bomb.blf"
    offset = blf_of(DATA / "paper-line.log", path)
    with path.open("ab") as f:
        f.write(container(inflating_to(BOMB_BYTES), 128 << 10))
    tracemalloc.start()
    try:
        with pytest.raises(LogError) as refused:
            read_log(path, db)  # type: ignore[arg-type]
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    message = str(refused.value)
    assert message.startswith(f"{path}: BLF container "), message
    assert f"at byte {offset} " in message, message
    assert "16 MiB" in message, message
    assert "\n" not in message
    assert peak < PEAK_LIMIT, f"{peak / 2**20:.0f} MiB allocated to read a 256 MiB bomb"


def test_the_whole_blf_log_is_bounded_too(
    tmp_path: Path, db: object, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Containers each within their bound, together beyond the log's: with
    the log's bound lowered to 64 kB, the paper-line log (about 2 MB of BLF
    objects) stops at the container that crosses it."""
    path = tmp_path / "bus.blf"
    blf_of(DATA / "paper-line.log", path)
    monkeypatch.setattr(blf, "MAX_LOG_BYTES", 64 << 10, raising=False)
    with pytest.raises(LogError) as refused:
        read_log(path, db)  # type: ignore[arg-type]
    message = str(refused.value)
    assert message.startswith(f"{path}: BLF container "), message
    assert "the whole log inflates to more than 64 KiB" in message, message


def test_a_blf_log_reads_as_python_can_reads_it(tmp_path: Path, db: object) -> None:
    """The bounded reader gives the frames python-can's BLFReader gives, in
    order, with their stamps (the reference is python-can's own reader)."""
    path = tmp_path / "bus.blf"
    blf_of(DATA / "paper-line.log", path)
    log = read_log(path, db)  # type: ignore[arg-type]
    want = [m for m in can.BLFReader(str(path))]
    assert len(log) == len(want)
    for k in (0, 1, len(want) // 2, len(want) - 1):
        frame = log.frame(k)
        assert frame.frame_id == want[k].arbitration_id
        assert bytes(frame.data) == bytes(want[k].data)
        assert frame.timestamp == want[k].timestamp


def test_a_blf_object_that_says_it_has_no_size_ends_the_read_as_damage(tmp_path: Path) -> None:
    """An object whose size field is 0 (less than its own header) never moves
    python-can's parser on: it yields the same CAN frame for ever, and the
    tools collected them until memory ran out, from a file of 93 kB. It is
    damage, reported with its container and offset; the frames before are
    used. Run in a process of its own, bounded in time and memory."""
    path = tmp_path / "zero.blf"
    offset = blf_of(DATA / "paper-line.log", path)
    frame = struct.pack("<HBBL8s", 1, 0, 8, 0x100, bytes(8))  # a CAN_MESSAGE
    obj = struct.pack("<4sHHLL", b"LOBJ", 32, 1, 0, 1) + struct.pack("<LHHQ", 1, 0, 0, 0) + frame
    body = struct.pack("<H6xL4x", 0, len(obj)) + obj  # method 0: not compressed
    with path.open("ab") as f:
        f.write(struct.pack("<4sHHLL", b"LOBJ", 16, 1, 16 + len(body), 10) + body)
    code = (
        "import resource, sys\n"
        "resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))\n"
        "from pathlib import Path\n"
        "from mstc.can.dbc import load_database\n"
        "from mstc.logs.read import read_log\n"
        "log = read_log(Path(sys.argv[1]), load_database())\n"
        "print(len(log)); print(*log.problems, sep='\\n')\n"
    )
    try:
        done = subprocess.run(
            [sys.executable, "-c", code, str(path)], capture_output=True, text=True, timeout=60
        )
    except subprocess.TimeoutExpired:
        pytest.fail("reading a BLF object of size 0 did not end within 60 s")
    assert done.returncode == 0, done.stderr
    count, *problems = done.stdout.splitlines()
    assert int(count) == len(list(can.LogReader(str(DATA / "paper-line.log"))))
    assert len(problems) == 1, problems
    assert f"container 5 at byte {offset}: an object of 0 bytes" in problems[0], problems
