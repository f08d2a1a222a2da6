# SPDX-License-Identifier: MIT
"""A CSV file of rows written in plan order as they come, resumable.

A command whose runs are numbered by a *plan* (``mstc sweep``: scene by scene,
strategy by strategy; each run's number is its *position*) writes their rows
through a :class:`RowFile`: a header, then one line a row (a row's fields
hold no line break), in the order of their positions, each flushed as it is
written, so the file is read while it grows and an interruption leaves whole
rows and at most one cut short. The rows come in from :func:`write` in order
(:func:`mstc.sweep.jobs.run_tasks` emits them so), a batch at a time.

Resuming, the caller says which old rows to keep: ``keep(row)`` gives the
position of a row (a dict of the header's columns) that is still good, or
None to run it again (a row of another plan, of a changed source, a damaged
one). Before anything runs, the good rows of the file, and of the resume
file an interrupted resume left, are copied in position order into the
resume file (``.<name>.resume`` beside it; a row kept twice is kept once),
and the file starts afresh; as the new rows come, the kept ones are copied
back among them, each at its place. The caller plans from
:meth:`RowFile.kept`, the sorted positions kept (8 bytes a row: the only
memory that grows with the file, and only when resuming). The resume file is
removed when :meth:`RowFile.finish` has written the last row.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path

import numpy as np

Keep = Callable[[Mapping[str, str]], int | None]
"""The position of an old row to keep, or None to run it again."""
Fields = Sequence[str]
"""A row's values, in the file's column order."""


class RowFile:
    """@p path written afresh with @p columns, or resumed (@p keep); close it
    (``contextlib.closing``) or :meth:`finish` it."""

    def __init__(self, path: Path, columns: Sequence[str], keep: Keep | None = None) -> None:
        self.path = path
        self.columns = tuple(columns)
        self._resume = path.with_name(f".{path.name}.resume")
        self.kept = np.zeros(0, dtype=np.int64)
        """The positions of the rows kept, sorted."""
        self._next = 0
        """Index in :attr:`kept` of the next kept row to copy back."""
        self._source: io.TextIOWrapper | None = None
        if keep is not None:
            self._compact(keep)
            if len(self.kept):
                self._source = self._resume.open(newline="")
                self._source.readline()  # the header
        self._file = path.open("w", newline="")
        self._csv = csv.writer(self._file, lineterminator="\n")
        self._csv.writerow(self.columns)
        self._file.flush()
        if keep is None or not len(self.kept):
            self._resume.unlink(missing_ok=True)

    def close(self) -> None:
        """Close the files (an unfinished file keeps its resume file)."""
        self._file.close()
        if self._source is not None:
            self._source.close()

    def _rows(self, path: Path) -> Iterator[tuple[Mapping[str, str], int, int]]:
        """The complete rows of @p path with their byte offsets and lengths;
        nothing when it is missing or has other columns."""
        try:
            f = path.open("rb")
        except FileNotFoundError:
            return
        with f:
            header = f.readline()
            if next(csv.reader([header.decode("utf-8", "replace")]), None) != list(self.columns):
                return
            offset = len(header)
            n = len(self.columns)
            for line in f:
                start, offset = offset, offset + len(line)
                if not line.endswith(b"\n"):
                    continue  # cut short by an interruption
                try:
                    fields = next(csv.reader([line.decode("utf-8")]))
                except (UnicodeDecodeError, csv.Error, StopIteration):
                    continue
                if len(fields) == n:
                    yield dict(zip(self.columns, fields, strict=True)), start, len(line)

    def _compact(self, keep: Keep) -> None:
        """Copy the good rows of the file and of an earlier resume file into
        a new resume file, in position order."""
        sources = [self.path, self._resume]
        positions, which, offsets, lengths = [], [], [], []
        for i, source in enumerate(sources):
            for row, offset, length in self._rows(source):
                position = keep(row)
                if position is not None:
                    positions.append(position)
                    which.append(i)
                    offsets.append(offset)
                    lengths.append(length)
        pos = np.array(positions, dtype=np.int64)
        order = np.lexsort((np.array(which, dtype=np.int64), pos))
        first = np.ones(len(order), dtype=bool)  # a position kept twice: the first file's
        first[1:] = pos[order][1:] != pos[order][:-1]
        order = order[first]
        tmp = self._resume.with_name(self._resume.name + ".tmp")
        handles = [s.open("rb") if s.exists() else None for s in sources]
        try:
            with tmp.open("wb") as out:
                out.write((",".join(self.columns) + "\n").encode())
                for k in order.tolist():
                    handle = handles[which[k]]
                    assert handle is not None
                    out.write(os.pread(handle.fileno(), lengths[k], offsets[k]))
        finally:
            for handle in handles:
                if handle is not None:
                    handle.close()
        tmp.replace(self._resume)
        self.kept = pos[order]

    def _copy_kept(self, before: int | None) -> list[list[str]]:
        """Copy back the kept rows before position @p before (None: all)."""
        if self._source is None:
            return []
        stop = len(self.kept) if before is None else int(np.searchsorted(self.kept, before))
        lines = [self._source.readline() for _ in range(self._next, stop)]
        self._next = max(self._next, stop)
        if lines:
            self._file.write("".join(lines))
        return [next(csv.reader([line])) for line in lines]

    def copy_kept(self, before: int) -> list[list[str]]:
        """Copy back now the kept rows before position @p before (those
        before the first run to make: runs.csv shows them at once, not when
        that run's row comes), then flush. Returns them."""
        copied = self._copy_kept(before)
        self._file.flush()
        return copied

    def write(self, rows: Iterable[tuple[int, Fields]]) -> list[list[str]]:
        """Write @p rows, (position, fields) in increasing positions after
        those written before, and the kept rows before and among them, then
        flush. Returns the kept rows copied back (for the caller's summary)."""
        copied: list[list[str]] = []
        batch: list[Fields] = []
        for position, fields in rows:
            if self._next < len(self.kept) and self.kept[self._next] <= position:
                self._csv.writerows(batch)
                batch = []
                copied += self._copy_kept(position)
                if self._next < len(self.kept) and self.kept[self._next] == position:
                    assert self._source is not None  # a row run again replaces the kept one
                    self._source.readline()
                    self._next += 1
            batch.append(fields)
        self._csv.writerows(batch)
        self._file.flush()
        return copied

    def finish(self) -> list[list[str]]:
        """Write the kept rows not written yet, close, and remove the resume
        file. Returns the kept rows copied back."""
        copied = self._copy_kept(None)
        self.close()
        self._resume.unlink(missing_ok=True)
        return copied
