# SPDX-License-Identifier: MIT
"""Bus logs in Vector's BLF format: python-can's ``BLFReader``, its
containers inflated a piece at a time within bounds.

A BLF file is a header and a sequence of objects, mostly LOG_CONTAINERs, each
a zlib stream of more objects (the CAN frames). python-can's reader inflates
each container whole before it looks at it, so one container of a few
hundred kilobytes that inflates to gigabytes (a zlib bomb) exhausts memory
before any check. Here each container is inflated :data:`CHUNK_BYTES` at a
time, each piece parsed by python-can's own object parser, and two bounds
hold: :data:`MAX_CONTAINER_BYTES` per container and :data:`MAX_LOG_BYTES`
for the whole log; beyond either the read stops with a :class:`LogError`
naming the container and its byte offset. An object whose size is less than
its own header, on which python-can's parser would turn for ever, is damage
(:func:`_check_sizes`).

Binary: a problem is reported by frame number. A file shorter than its header
says (a recording cut off) is reported, and the frames before are used. mstc
writes no BLF files (its runs write candump -L).
"""

from __future__ import annotations

import zlib
from collections.abc import Generator, Iterator
from pathlib import Path

import can
from can.io.blf import (
    LOG_CONTAINER,
    LOG_CONTAINER_STRUCT,
    NO_COMPRESSION,
    OBJ_HEADER_BASE_STRUCT,
    ZLIB_DEFLATE,
    BLFParseError,
)

from mstc.errors import LogError
from mstc.logs.framelog import FrameLog, LogProblem, ProblemKind, ProblemList, read_messages

CHUNK_BYTES = 1 << 16
"""Bytes read from the file, and inflated from it, at a time."""
MAX_CONTAINER_BYTES = 16 << 20
"""The most one container may inflate to [bytes]: 16 MiB, 128 times the
128 KiB containers Vector's loggers and python-can write."""
MAX_LOG_BYTES = 1 << 30
"""The most the whole log may inflate to [bytes]: 1 GiB, some 22 million
classic CAN frames (48 bytes each as BLF objects)."""
MAX_OBJECT_BYTES = 1 << 20
"""The most one object may span across pieces and containers [bytes]: a CAN
frame's object is under 200 bytes."""


def _size(n: int) -> str:
    """@p n bytes in KiB, MiB or GiB, as the bounds are given."""
    for unit, shift in (("GiB", 30), ("MiB", 20), ("KiB", 10)):
        if n >= 1 << shift and n % (1 << shift) == 0:
            return f"{n >> shift} {unit}"
    return f"{n} bytes"


def _check_sizes(data: bytes) -> None:
    """Walk the objects of @p data as python-can's parser does (each at the
    next "LOBJ" within 8 bytes, the next one its size further on) up to the
    first it cannot see whole.

    :raises BLFParseError: an object smaller than its base header: python-can
        would never move past it (the same frame yielded for ever).
    """
    pos = 0
    while (at := data.find(b"LOBJ", pos, pos + 8)) >= 0:
        if at + OBJ_HEADER_BASE_STRUCT.size > len(data):
            return
        obj_size = OBJ_HEADER_BASE_STRUCT.unpack_from(data, at)[3]
        if obj_size < OBJ_HEADER_BASE_STRUCT.size:
            raise BLFParseError(f"an object of {obj_size} bytes, less than its header")
        pos = at + obj_size


class BoundedBLFReader(can.BLFReader):
    """python-can's BLF reader with bounded, piecewise inflation (see the
    module).

    :raises LogError: while iterating: a container or the log inflates beyond
        its bound, or an object spans more than :data:`MAX_OBJECT_BYTES`.
    """

    def __init__(self, path: Path) -> None:
        super().__init__(str(path))
        self.path = path
        self._inflated = 0
        """Bytes the log inflated to so far."""

    def __iter__(self) -> Generator[can.Message, None, None]:
        index = 0
        while True:
            offset = self.file.tell()
            head = self.file.read(OBJ_HEADER_BASE_STRUCT.size)
            if not head:
                break  # end of file
            if len(head) < OBJ_HEADER_BASE_STRUCT.size:
                raise BLFParseError(f"an object header cut off at byte {offset}")
            signature, _, _, obj_size, obj_type = OBJ_HEADER_BASE_STRUCT.unpack(head)
            if signature != b"LOBJ":
                raise BLFParseError(f"no object at byte {offset}")
            body = max(obj_size - OBJ_HEADER_BASE_STRUCT.size, 0)
            if obj_type == LOG_CONTAINER:
                index += 1
                yield from self._container(index, offset, body)
            else:
                self.file.seek(body, 1)
            self.file.seek(obj_size % 4, 1)  # padding
        self.stop()

    def _container(self, index: int, offset: int, body: int) -> Iterator[can.Message]:
        """The frames of container @p index (from 1) at byte @p offset, whose
        object holds @p body bytes after its header."""
        head = self.file.read(LOG_CONTAINER_STRUCT.size)
        if len(head) < LOG_CONTAINER_STRUCT.size:
            raise BLFParseError(f"container {index} cut off at byte {offset}")
        method, _ = LOG_CONTAINER_STRUCT.unpack(head)
        left = body - LOG_CONTAINER_STRUCT.size
        if method not in (NO_COMPRESSION, ZLIB_DEFLATE):
            self.file.seek(max(left, 0), 1)  # python-can skips it too
            return
        inflate = zlib.decompressobj() if method == ZLIB_DEFLATE else None
        size = 0
        while left > 0 or (inflate is not None and inflate.unconsumed_tail):
            if inflate is not None and inflate.unconsumed_tail:
                raw = inflate.unconsumed_tail
            else:
                raw = self.file.read(min(left, CHUNK_BYTES))
                if not raw:
                    break  # the file ends inside the container
                left -= len(raw)
            data = inflate.decompress(raw, CHUNK_BYTES) if inflate is not None else raw
            size += len(data)
            self._inflated += len(data)
            where = f"{self.path}: BLF container {index} at byte {offset}"
            if size > MAX_CONTAINER_BYTES:
                raise LogError(
                    f"{where} inflates to more than {_size(MAX_CONTAINER_BYTES)}, "
                    "the bound of one container (docs/replay.md): refused"
                )
            if self._inflated > MAX_LOG_BYTES:
                raise LogError(
                    f"{where}: the whole log inflates to more than {_size(MAX_LOG_BYTES)}, "
                    "the bound of a BLF log (docs/replay.md): refused"
                )
            try:
                _check_sizes(self._tail + data)
                yield from self._parse_container(data)
            except BLFParseError as exc:  # damage: the caller keeps the frames before
                raise BLFParseError(f"container {index} at byte {offset}: {exc}") from exc
            if len(self._tail) > MAX_OBJECT_BYTES:
                raise LogError(
                    f"{where}: an object spans more than {_size(MAX_OBJECT_BYTES)}: "
                    "not a BLF file, or a damaged one"
                )


def read_blf(path: Path, max_problems: int) -> FrameLog:
    """The frames of the BLF file @p path, its problems by frame number.

    :raises LogError: it cannot be read at all, or it inflates beyond a bound
        (:class:`BoundedBLFReader`).
    """
    problems = ProblemList(max_problems)
    try:
        reader = BoundedBLFReader(path)
    except Exception as exc:  # python-can raises what its parser meets
        raise LogError(f"{path}: not a readable BLF file: {exc}") from exc
    cols, number = read_messages(path, "blf", reader, problems)
    declared = getattr(reader, "file_size", 0)  # the writer's size, set on closing
    actual = path.stat().st_size
    if declared and actual < declared:
        problems.append(
            LogProblem(
                f"{path}: after frame {number}",
                number,
                ProblemKind.READ,
                f"truncated: the header says {declared} bytes, the file has {actual}; "
                "the frames before are used",
            )
        )
    return cols.build(path, "blf", problems, number)
