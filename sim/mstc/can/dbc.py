# SPDX-License-Identifier: MIT
"""The DBC and its value tables: the only source of the wire's numbers on the
Python side.

The Python side names things: the parameters it writes (``R_m``, ``arm``), the
answer it checks for (``ok``), the modes, event kinds and sides it decodes
into :class:`~mstc.model.Mode`, :class:`~mstc.model.EventKind` and
:class:`~mstc.model.Side`. It holds none of their numbers: they are
looked up here, in the DBC's value tables (``VAL_`` of a signal,
``VAL_TABLE_`` for a global one), once per loaded DBC, as the firmware's C
side gets them from the codec generated from the same file.

What an edit of the DBC does to the Python side:

- an entry renumbered: followed (the new number is written and decoded);
- an entry renamed that the Python side names (a :data:`~mstc.model.PARAM_NAMES`
  parameter, ``arm``, ``ok``, a member of one of the enums above):
  :class:`~mstc.errors.DbcError` when the tables are built, naming the DBC,
  the table and the entry;
- an entry renamed or added that it does not name (a halt reason, mode
  ``blocked``): followed where names are shown (status.csv and replay
  reports print the DBC's names); the decoders treat a value without a
  Python member as unknown, as before.

The DBC ships inside the package (``mstc/can/mstc.dbc``, in the source tree a
symbolic link to ``firmware/comm/mstc.dbc``), so an installed ``mstc`` finds it.
"""

from __future__ import annotations

import functools
import weakref
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import TypeVar

import cantools
from cantools.database.can import Database, Message

from mstc.errors import DbcError, DbcLoadError
from mstc.model import PARAM_NAMES, EventKind, Mode, Side

DBC_PATH = Path(__file__).parent / "mstc.dbc"
"""The protocol's DBC, shipped in the package (firmware/comm/mstc.dbc)."""

E = TypeVar("E", bound=StrEnum)

_SOURCES: weakref.WeakKeyDictionary[Database, str] = weakref.WeakKeyDictionary()
"""The file each database was loaded from, for error messages."""
_TABLES: weakref.WeakKeyDictionary[Database, Tables] = weakref.WeakKeyDictionary()
"""The tables of each database, built once."""


E2E_SIGNALS = ("CRC", "Counter")
"""The E2E protection's signals of every message (short names)."""


def short_name(message: Message, signal: str) -> str:
    """A signal's name without its message prefix: ``x`` for ``ODOM_XY_x``."""
    return signal.removeprefix(f"{message.name}_")


def signal_values(
    message: Message, data: bytes, *, choices: bool = False
) -> dict[str, float | int | str]:
    """The signals of a frame of @p message by short name, scaled; with
    @p choices, value-table entries by name (a raw value outside the table
    stays a number).

    :raises Exception: cantools' errors for data it cannot decode.
    """
    values = message.decode(data, decode_choices=choices, scaling=True)
    if not isinstance(values, dict):
        raise TypeError(f"{message.name} is a container message, which mstc does not use")
    return {
        short_name(message, name): value if isinstance(value, int | float) else str(value)
        for name, value in values.items()
    }


def numeric_values(message: Message, data: bytes) -> dict[str, float | int]:
    """The signals of a frame of @p message by short name, scaled, value-table
    entries as numbers (see :func:`signal_values`)."""
    values = signal_values(message, data)
    return {name: value for name, value in values.items() if not isinstance(value, str)}


def e2e_data_ids(db: Database) -> dict[int, int]:
    """The ``E2EDataID`` attribute of each message that has one, by identifier."""
    return {
        m.frame_id: int(m.dbc.attributes["E2EDataID"].value)
        for m in db.messages
        if m.dbc is not None and "E2EDataID" in m.dbc.attributes
    }


def load_database(path: Path = DBC_PATH) -> Database:
    """Load the protocol's DBC, strictly (overlapping signals are an error).

    :raises DbcLoadError: the file cannot be read or is not a valid CAN DBC.
    """
    try:
        db = cantools.database.load_file(path, strict=True)
    except Exception as exc:  # cantools raises several kinds on a bad file
        raise DbcLoadError(f"cannot load the DBC {path}: {exc}") from exc
    if not isinstance(db, Database):
        raise DbcLoadError(f"cannot load the DBC {path}: not a CAN database")
    _SOURCES[db] = str(path)
    return db


@dataclass(frozen=True)
class ValueTable:
    """One value table of the DBC: raw values and their names."""

    dbc: str
    """The DBC file, for error messages."""
    name: str
    """The table: ``<message>_<signal>`` for a signal's, else the global name."""
    entries: Mapping[int, str]
    """Name by raw value."""

    def value(self, entry: str) -> int:
        """The raw value of @p entry.

        :raises DbcError: no entry of that name.
        """
        for raw, name in self.entries.items():
            if name == entry:
                return raw
        have = ", ".join(f"{raw} {name!r}" for raw, name in self.entries.items())
        raise DbcError(self.dbc, self.name, entry, f"no entry {entry!r} (it has {have})")

    def name_of(self, raw: int) -> str | None:
        """The name of @p raw, or None when the table has no such value."""
        return self.entries.get(raw)

    def members(self, enum: type[E]) -> dict[int, E]:
        """Raw value -> member of @p enum, matching entry names to member values.

        :raises DbcError: a member has no entry.
        """
        return {self.value(member.value): member for member in enum}


def _signal_table(db: Database, dbc: str, message: str, signal: str) -> ValueTable:
    try:
        choices = db.get_message_by_name(message).get_signal_by_name(f"{message}_{signal}").choices
    except KeyError as exc:
        table = f"{message}_{signal}"
        raise DbcError(dbc, table, table, f"no signal {table} in message {message}") from exc
    entries = {int(raw): str(name) for raw, name in (choices or {}).items()}
    return ValueTable(dbc, f"{message}_{signal}", entries)


def _same(first: ValueTable, *others: ValueTable) -> ValueTable:
    """@p first, after checking that @p others hold the same entries."""
    for other in others:
        if dict(other.entries) != dict(first.entries):
            differ = sorted(
                set(first.entries.items()) ^ set(other.entries.items()), key=lambda e: e[0]
            )
            raw, name = differ[0]
            raise DbcError(
                first.dbc,
                other.name,
                name,
                f"differs from {first.name} at {raw} {name!r}: the two must be the same table",
            )
    return first


@dataclass(frozen=True)
class Tables:
    """The value tables the Python side uses, checked to hold every name it needs."""

    dbc: str
    """The DBC file."""
    param_index: ValueTable
    """PARAM_SET_index (checked equal to PARAM_GET_index and PARAM_VALUE_index)."""
    param_result: ValueTable
    """PARAM_VALUE_result."""
    halt: ValueTable
    """STATUS_halt: why the firmware holds the robot."""
    strategy: ValueTable
    """The global table Strategy: values of the ``strategy`` parameter."""
    mode: dict[int, Mode]
    """STATUS_mode (and the in-process library's mode)."""
    event_kind: dict[int, EventKind]
    """EVENT_kind (and the in-process library's event kind)."""
    side: dict[int, Side | None]
    """STATUS_side and EVENT_side (the same table); ``none`` is None."""
    param_indexes: dict[str, int]
    """PARAM_SET index of each :data:`~mstc.model.PARAM_NAMES` parameter."""
    arm_index: int
    """PARAM_SET index of the arm command (value 1 arms, 0 disarms)."""
    param_ok: int
    """PARAM_VALUE_result of an accepted write."""

    @classmethod
    def build(cls, db: Database, dbc: str) -> Tables:
        """The tables of @p db (loaded from @p dbc).

        :raises DbcError: a table or an entry the Python side names is missing,
            or two tables that must agree differ.
        """
        index = _same(
            _signal_table(db, dbc, "PARAM_SET", "index"),
            _signal_table(db, dbc, "PARAM_GET", "index"),
            _signal_table(db, dbc, "PARAM_VALUE", "index"),
        )
        result = _signal_table(db, dbc, "PARAM_VALUE", "result")
        side = _same(
            _signal_table(db, dbc, "STATUS", "side"), _signal_table(db, dbc, "EVENT", "side")
        )
        sides: dict[int, Side | None] = {side.value("none"): None}
        sides.update(side.members(Side))
        globals_ = db.dbc.value_tables if db.dbc is not None else {}
        if "Strategy" not in globals_:
            raise DbcError(dbc, "Strategy", "Strategy", "no global value table Strategy")
        strategy = ValueTable(
            dbc, "Strategy", {int(raw): str(name) for raw, name in globals_["Strategy"].items()}
        )
        return cls(
            dbc=dbc,
            param_index=index,
            param_result=result,
            halt=_signal_table(db, dbc, "STATUS", "halt"),
            strategy=strategy,
            mode=_signal_table(db, dbc, "STATUS", "mode").members(Mode),
            event_kind=_signal_table(db, dbc, "EVENT", "kind").members(EventKind),
            side=sides,
            param_indexes={name: index.value(name) for name in PARAM_NAMES},
            arm_index=index.value("arm"),
            param_ok=result.value("ok"),
        )


def tables(db: Database | None = None) -> Tables:
    """The value tables of @p db (default: the package's DBC), built once per database.

    :raises DbcError: see :meth:`Tables.build`.
    """
    if db is None:
        db = _default_database()
    found = _TABLES.get(db)
    if found is None:
        found = Tables.build(db, _SOURCES.get(db, "the DBC"))
        _TABLES[db] = found
    return found


@functools.cache
def _default_database() -> Database:
    """The package's DBC, loaded once."""
    return load_database()
