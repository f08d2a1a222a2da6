# SPDX-License-Identifier: MIT
"""The errors of mstc, in one place.

Every error the package raises on purpose derives from :class:`MstcError`,
so a caller can catch them all; each subclass names what failed. The
command line (:mod:`mstc.cli`) turns them into one ``error: ...`` line and an
exit status.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mstc.logs.play import PlayStats


class MstcError(Exception):
    """Base of every error mstc raises on purpose."""


class ScenarioError(MstcError, ValueError):
    """A scenario file that cannot be used.

    :param path: the file, as the user named it.
    :param key: dotted path of the offending key, or None for the whole file.
    :param problem: what is wrong.
    """

    def __init__(self, path: str, key: str | None, problem: str) -> None:
        self.path = path
        self.key = key
        self.problem = problem
        where = f"{path}: {key}" if key else path
        # One line, whatever the file name, key or parser message hold.
        super().__init__(" ".join(f"{where}: {problem}".split()))


class FirmwareError(MstcError):
    """The firmware library or executable cannot be loaded or started, rejects
    its parameters, or a step fails."""


class DbcError(MstcError):
    """The DBC lacks a value-table entry the Python side names (a parameter
    index, a mode, an event kind, ...), or its tables disagree.

    :param dbc: the DBC file, as loaded.
    :param table: the value table (``STATUS_mode``, ``Strategy``, ...).
    :param entry: the entry's name.
    :param problem: what is wrong with it.
    """

    def __init__(self, dbc: str, table: str, entry: str, problem: str) -> None:
        self.dbc = dbc
        self.table = table
        self.entry = entry
        super().__init__(f"{dbc}: value table {table}: {problem}")


class ControllerError(MstcError):
    """The firmware did not answer as the protocol says."""


class LogError(MstcError):
    """A log that cannot be used at all (fatal: nothing is replayed)."""


class SendError(MstcError):
    """A frame could not be sent; :attr:`stats` says how far the play came."""

    def __init__(self, message: str, stats: PlayStats) -> None:
        super().__init__(message)
        self.stats = stats


class SimulationError(MstcError):
    """A closed-loop run that could not go on: the plant's state became
    non-finite, or the loop raised."""


class RosError(MstcError):
    """The ROS 2 side cannot run: its packages are not installed
    (``pip install 'mstc[ros]'``), or a bridge parameter, the bus or the
    firmware behind it is not usable."""
