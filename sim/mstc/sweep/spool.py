# SPDX-License-Identifier: MIT
"""The client's spool: every parsed scene of a sweep on disk, not in memory.

``mstc sweep`` parses and validates every scene before it runs any (every
problem is reported before anything runs), then runs them batch by batch.
Holding each parsed scenario (some 4 kB) and its text (1 kB) until the
end would make the client's memory grow with the sweep, so the validation
pass pickles each parsed scenario into the spool and keeps a
small record (:meth:`mstc.sweep.engine.Scene.from_scenario`); a batch reads
its scenes back when it is sent (:func:`mstc.sweep.engine.shipped`), as the
bytes the worker unpickles, and so the client holds only the batches in flight.

The spool is an unnamed temporary file in the sweep's output folder (a file
unlinked as soon as it is created, ``O_TMPFILE`` on Linux): nothing is left
behind however the sweep ends, and no other sweep can read it. It takes
about 2 kB of disk a scene.
"""

from __future__ import annotations

import os
import pickle
import tempfile
from pathlib import Path
from types import TracebackType

from mstc.plant.scenario import Scenario


class Spool:
    """Parsed scenes pickled into an unnamed file of @p folder, found by the
    scene's name (an index of offsets)."""

    def __init__(self, folder: Path) -> None:
        self._file = tempfile.TemporaryFile(dir=folder, prefix=".spool-")
        self._index: dict[str, tuple[int, int]] = {}
        self._end = 0

    def __enter__(self) -> Spool:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Close the file (and so remove it)."""
        self._file.close()

    def __len__(self) -> int:
        return len(self._index)

    def __contains__(self, name: object) -> bool:
        return name in self._index

    @property
    def size(self) -> int:
        """Bytes written [B]."""
        return self._end

    def add(self, name: str, scenario: Scenario) -> None:
        """Spool the scene @p name, parsed into @p scenario."""
        data = pickle.dumps(scenario, protocol=pickle.HIGHEST_PROTOCOL)
        self._file.write(data)
        self._index[name] = (self._end, len(data))
        self._end += len(data)

    def read(self, name: str) -> bytes:
        """The scene @p name's scenario, pickled.

        :raises KeyError: no such scene.
        """
        offset, length = self._index[name]
        self._file.flush()
        data = os.pread(self._file.fileno(), length, offset)
        if len(data) != length:
            raise OSError(f"the sweep's spool lost scene {name} (read {len(data)} of {length} B)")
        return data
