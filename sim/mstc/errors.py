# SPDX-License-Identifier: MIT
"""The errors of mstc, in one place, and the exit statuses of the command.

Every error the package raises on purpose derives from :class:`MstcError`, so
a caller can catch them all; each subclass names what failed, in a message of
one line (or one line per problem, for the errors that gather several). The
command line (:func:`mstc.cli.main`) catches them in one place, prints each
line as ``error: ...`` and exits with the error's :attr:`~MstcError.exit_status`.

This module imports nothing but the standard library, so every layer of the
package can raise its errors (docs/architecture.md, "The Python package").
"""

from __future__ import annotations

import enum
from collections.abc import Iterator
from contextlib import contextmanager

EXIT_OK = 0
"""Done."""
EXIT_FAILED = 1
"""The run failed: the firmware could not be run, its frames differ from a
log's, a send failed, or an output could not be written."""
EXIT_USAGE = 2
"""Bad arguments or bad input (a scenario file, a log): nothing was run."""
EXIT_NO_TARGET = 3
"""The firmware library cannot be loaded (``mstc replay``), or the bus cannot
be opened (``mstc play``)."""
EXIT_MISSED = 4
"""The run was done, but missed what its scenario expects: an ``[[expected]]``
event beyond its tolerance, a contact with an obstacle (COLLISION), or a
firmware that ended the run halted
(``mstc sim``, ``mstc hil``)."""
EXIT_INTERRUPTED = 130
"""Interrupted (Ctrl-C)."""


class MstcError(Exception):
    """Base of every error mstc raises on purpose."""

    exit_status = EXIT_FAILED
    """The command's exit status when this error ends it."""


class UsageError(MstcError, ValueError):
    """Bad arguments, or several bad inputs, found before anything ran: one
    line per problem."""

    exit_status = EXIT_USAGE


class ScenarioError(MstcError, ValueError):
    """A scenario file that cannot be used.

    :param path: the file, as the user named it.
    :param key: dotted path of the offending key, or None for the whole file.
    :param problem: what is wrong.
    """

    exit_status = EXIT_USAGE

    def __init__(self, path: str, key: str | None, problem: str) -> None:
        self.path = path
        self.key = key
        self.problem = problem
        where = f"{path}: {key}" if key else path
        # One line, whatever the file name, key or parser message hold.
        super().__init__(" ".join(f"{where}: {problem}".split()))


class SuiteError(ScenarioError):
    """A suite file that cannot be used (same one-line form as a scenario's)."""


class TableError(MstcError, ValueError):
    """The limits table (firmware/ctrl/ctl_params.toml) itself is malformed."""


class DbcError(MstcError):
    """The DBC lacks a value-table entry the Python side names (a parameter
    index, a mode, an event kind, ...), or its tables disagree.

    :param dbc: the DBC file, as loaded.
    :param table: the value table (``STATUS_mode``, ``Strategy``, ...).
    :param entry: the entry's name.
    :param problem: what is wrong with it.
    """

    exit_status = EXIT_USAGE

    def __init__(self, dbc: str, table: str, entry: str, problem: str) -> None:
        self.dbc = dbc
        self.table = table
        self.entry = entry
        super().__init__(f"{dbc}: value table {table}: {problem}")


class DbcLoadError(MstcError):
    """A DBC file that cannot be loaded: missing, unreadable, or not a valid DBC."""

    exit_status = EXIT_USAGE


class SignalRangeError(MstcError, ValueError):
    """A value its signal cannot carry: refused by the encoder instead of clipped.

    :param frame: message name, e.g. ``"OBSTACLE"``.
    :param signal: the signal's short name, e.g. ``"id"``.
    :param value: the value asked for.
    :param limits: the range it must lie in.
    :param unit: the signal's unit, or what the range is of (``"raw, 4 bits"``).
    """

    def __init__(
        self, frame: str, signal: str, value: float, limits: tuple[float, float], unit: str
    ) -> None:
        lo, hi = limits
        what = f" {unit}" if unit else ""
        super().__init__(
            f"{frame}.{signal} = {value:.10g}{what} is outside its range "
            f"[{lo:.10g}, {hi:.10g}]{what}: not sent"
        )
        self.frame = frame
        self.signal = signal
        self.value = value
        self.limits = limits


class FrameDropped(MstcError):
    """A received frame failed a check; it has been counted in
    :attr:`mstc.can.protocol.Protocol.drops`.

    :param reason: why (a :class:`mstc.can.protocol.DropReason`).
    """

    def __init__(self, reason: enum.Enum, frame_id: int, detail: str) -> None:
        super().__init__(f"frame 0x{frame_id:03X} dropped ({reason.value}): {detail}")
        self.reason = reason
        self.frame_id = frame_id


class AuthKeyError(MstcError):
    """No key for authenticated commands, or not a key."""

    exit_status = EXIT_USAGE


class FirmwareError(MstcError):
    """The firmware library or executable cannot be loaded or started, rejects
    its parameters, or a step fails."""


class ControllerError(MstcError):
    """The firmware did not answer as the protocol says."""


class SimulationError(MstcError):
    """A closed-loop run that could not go on: the plant's state became
    non-finite, or the loop raised."""


class StackUnbounded(MstcError):
    """A board image's call graph with a cycle (recursion): its stack depth has
    no bound (:mod:`mstc.bench.budget`); the message is the cycle."""


class RunError(MstcError):
    """A scenario's run that failed, named with its file (the command line's
    account of a :class:`FirmwareError`, :class:`ControllerError`, a bus error...)."""


class ExpectationError(MstcError):
    """A run that missed what its scenario expects (one line per scenario);
    its outputs are written."""

    exit_status = EXIT_MISSED


class DependencyError(MstcError):
    """An optional dependency that is not installed (an extra of the package:
    ``pip install 'mstc[cluster]'``, ``pip install 'mstc[ros]'``)."""

    exit_status = EXIT_USAGE


class ClusterError(MstcError):
    """A Dask cluster that cannot be reached."""


class LogError(MstcError):
    """A log that cannot be used at all (fatal: nothing is replayed)."""

    exit_status = EXIT_USAGE


class BusError(MstcError):
    """A bus that cannot be opened."""

    exit_status = EXIT_NO_TARGET


class SendError(MstcError):
    """A frame could not be sent."""


class OutputError(MstcError):
    """An output folder that cannot be written without leaving OUT or destroying
    files mstc did not write; nothing is written."""

    exit_status = EXIT_USAGE


class WriteError(MstcError):
    """An output that could not be written (the file system said no)."""


@contextmanager
def writing(what: str) -> Iterator[None]:
    """Turn an :class:`OSError` raised while writing @p what into a
    :class:`WriteError`: ``cannot write <what>: <why>``."""
    try:
        yield
    except OSError as exc:
        raise WriteError(f"cannot write {what}: {exc}") from exc
