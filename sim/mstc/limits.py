# SPDX-License-Identifier: MIT
"""The limits of every controller parameter: ``firmware/ctrl/ctl_params.toml``.

One table, read here by the scenario loader and by ``tools/gen-limits``, which
writes the firmware's copy (``firmware/ctrl/ctl_limits.[ch]``) from it, so the
loader and the firmware's check (``ctl_params_verdict``) cannot disagree.

A parameter set is accepted when every value lies within its [min, max] and
every relation holds. As in the firmware, the check runs on the values as the
firmware holds them, in each way it may hold them: single-precision float;
Q16.16 from a PARAM_SET frame's float (``num_from_float``); Q16.16 from the
in-process library's double (``mstc_sil_init``). Sums and products are
rounded as the firmware rounds them (float, or libfixmath's ``fix16_smul``).
So a value is never accepted here that the firmware would refuse, nor the
other way round.
"""

from __future__ import annotations

import enum
import itertools
import math
import struct
import tomllib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from mstc.errors import TableError
from mstc.model import PARAMS_TABLE

TABLE_PATH = PARAMS_TABLE
"""The table: firmware/ctrl/ctl_params.toml (a link to it in the source tree,
its copy in an installed package)."""
DBC_PATH = Path(__file__).parent / "can" / "mstc.dbc"
"""The DBC, whose global value tables name an enumerated parameter's values."""

OPS = {">=": "GE", "<": "LT", "<=": "LE"}
"""Relation operators, and the name of each in the firmware (CTL_REL_*)."""


@dataclass(frozen=True)
class Limit:
    """One parameter of the table (a ``[[param]]``)."""

    index: int
    """PARAM_SET / PARAM_GET index."""
    name: str
    """Its name in the DBC's value table of PARAM_SET_index."""
    member: str
    """The ctl_params_t member that holds it; empty when none does yet."""
    scenario: str
    """Its key in a scenario's [params] (``tracking_gains[0]``: element k1 of
    that array); empty when a scenario cannot set it."""
    unit: str
    default: float
    minimum: float
    maximum: float
    control_law: bool
    """Accepted only while the robot is not armed."""
    why: str
    choices: tuple[str, ...] = ()
    """An enumerated parameter's values, in order (its range is 0 .. n-1)."""
    carried_by: str = ""
    """``MESSAGE.signal`` of the DBC whose range must hold [minimum, maximum]."""

    @property
    def held(self) -> bool:
        """Whether the firmware holds it (and so checks it)."""
        return bool(self.member)


@dataclass(frozen=True)
class Relation:
    """``lhs op factor × (sum of rhs)`` (a ``[[relation]]``)."""

    lhs: str
    op: str
    factor: float
    rhs: tuple[str, ...]
    why: str

    def text(self) -> str:
        """E.g. ``D_s >= R_m + R_ob``."""
        total = " + ".join(self.rhs)
        if self.factor != 1.0:
            total = f"{self.factor:g} × " + (f"({total})" if len(self.rhs) > 1 else total)
        return f"{self.lhs} {self.op} {total}"


@dataclass(frozen=True)
class Table:
    """The whole table."""

    params: tuple[Limit, ...]
    relations: tuple[Relation, ...]
    halt: Mapping[str, float]
    """The figures the deceleration bound is derived from (section [halt])."""

    def by_name(self, name: str) -> Limit:
        """The parameter called @p name."""
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(name)


@cache
def _value_table(name: str) -> tuple[str, ...]:
    """The names of the DBC's global value table @p name, by raw value 0, 1, ..."""
    from cantools.database.can import Database  # only for an enumerated parameter

    db = Database()
    db.add_dbc_file(str(DBC_PATH))
    tables = db.dbc.value_tables if db.dbc is not None else {}
    if name not in tables:
        raise TableError(f"{DBC_PATH}: no value table {name!r}")
    entries = {int(raw): str(text) for raw, text in tables[name].items()}
    if sorted(entries) != list(range(len(entries))):
        raise TableError(f"{DBC_PATH}: value table {name!r} is not 0, 1, ...: {entries}")
    return tuple(entries[i] for i in range(len(entries)))


def _limit(entry: Mapping[str, object], where: str) -> Limit:
    try:
        table = entry.get("value_table")
        choices = _value_table(str(table)) if table is not None else ()
        lo, hi = (0.0, float(len(choices) - 1)) if choices else (entry["min"], entry["max"])
        return Limit(
            index=int(entry["index"]),  # type: ignore[call-overload]
            name=str(entry["name"]),
            member=str(entry["member"]),
            scenario=str(entry["scenario"]),
            unit=str(entry["unit"]),
            default=float(entry["default"]),  # type: ignore[arg-type]
            minimum=float(lo),  # type: ignore[arg-type]
            maximum=float(hi),  # type: ignore[arg-type]
            control_law=bool(entry["control_law"]),
            why=str(entry["why"]),
            choices=choices,
            carried_by=str(entry.get("carried_by", "")),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise TableError(f"{where}: {exc!r}") from exc


@cache
def load_table(path: Path = TABLE_PATH) -> Table:
    """Read and check the table.

    :raises TableError: it is malformed: indices not rising from 0 (an
        index may be left out: reserved for a parameter not in the table yet,
        which the firmware answers unknown_index), a parameter no ctl_params_t
        member holds (the firmware's check reads every row), a relation naming
        an unknown parameter, an unknown operator, a default outside its range.
    """
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    params = tuple(_limit(e, f"{path}: param {i}") for i, e in enumerate(data.get("param", [])))
    indices = [p.index for p in params]
    if indices[:1] != [0] or any(b <= a for a, b in itertools.pairwise(indices)):
        raise TableError(f"{path}: the indices must rise from 0, in order")
    for p in params:
        if not p.held:
            raise TableError(f"{path}: {p.name}: no ctl_params_t member holds it (member)")
        if not p.minimum <= p.default <= p.maximum:
            raise TableError(f"{path}: {p.name}: default {p.default:g} outside its range")
    held = {p.name for p in params if p.held}
    relations = []
    for i, e in enumerate(data.get("relation", [])):
        try:
            r = Relation(
                str(e["lhs"]), str(e["op"]), float(e["factor"]), tuple(e["rhs"]), str(e["why"])
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise TableError(f"{path}: relation {i}: {exc!r}") from exc
        if r.op not in OPS or not 1 <= len(r.rhs) <= 2 or r.factor <= 0.0:
            raise TableError(f"{path}: relation {i}: op {r.op}, {len(r.rhs)} terms, factor")
        for name in (r.lhs, *r.rhs):
            if name not in held:
                raise TableError(f"{path}: relation {i}: {name} is not a held parameter")
        relations.append(r)
    return Table(params, tuple(relations), dict(data.get("halt", {})))


# --------------------------------------------- the numbers the firmware holds

Q_MAX = 2**31 - 1
Q_MIN = -(2**31)


def f32(x: float) -> float:
    """@p x rounded to single precision (to nearest, ties to even), ±inf beyond."""
    try:
        rounded: float = struct.unpack("<f", struct.pack("<f", x))[0]
    except OverflowError:
        return math.copysign(math.inf, x)
    return rounded


def _round_away(v: float) -> int:
    """Round to nearest, halves away from zero (C's round())."""
    return int(math.copysign(math.floor(abs(v) + 0.5), v))


def q_from_double(x: float) -> int:
    """Q16.16 of a double as the in-process library converts it (from_d in
    hal/sil/mstc_sil.c), or as NUM_C() does a constant: rounded to nearest,
    halves away from zero, saturated; non-finite gives 0."""
    if not math.isfinite(x):
        return 0
    v = x * 65536.0
    if v >= 2147483647.5:
        return Q_MAX
    if v <= -2147483648.5:
        return Q_MIN
    return _round_away(v)


def q_from_float(x: float) -> int:
    """Q16.16 of @p x sent as a float32 (a PARAM_SET value): num_from_float()."""
    f = f32(x)
    if math.isnan(f):
        return 0
    if f >= 32768.0:
        return Q_MAX
    if f < -32768.0:
        return Q_MIN
    return _round_away(f * 65536.0)  # exact: a power-of-two scale


def q_add(a: int, b: int) -> int:
    """num_add() in fixed mode: saturating."""
    return min(max(a + b, Q_MIN), Q_MAX)


def q_mul(a: int, b: int) -> int:
    """num_mul() in fixed mode: libfixmath's fix16_smul (rounding on)."""
    p = a * b
    upper = p >> 47
    if p < 0:
        if upper != -1:
            return Q_MIN if (a >= 0) != (b >= 0) else Q_MAX
        p -= 1
    elif upper != 0:
        return Q_MAX if (a >= 0) == (b >= 0) else Q_MIN
    return (p >> 16) + ((p & 0x8000) >> 15)


class Held(enum.Enum):
    """A way the firmware may hold a value."""

    FLOAT = "float"
    """Float build: single precision."""
    FIXED_FRAME = "fixed, from a PARAM_SET frame"
    """Fixed build, set over the bus: the frame's float32, then Q16.16."""
    FIXED_DOUBLE = "fixed, from the in-process library"
    """Fixed build, set through mstc_sil_init: the double, then Q16.16."""

    @property
    def fixed(self) -> bool:
        return self is not Held.FLOAT

    def hold(self, x: float) -> float | int:
        """@p x as this way holds it."""
        if self is Held.FLOAT:
            return f32(x)
        if self is Held.FIXED_FRAME:
            return q_from_float(x)
        return q_from_double(x)

    def constant(self, x: float) -> float | int:
        """A limit as the firmware's NUM_C() holds it."""
        return f32(x) if self is Held.FLOAT else q_from_double(x)

    def add(self, a: float | int, b: float | int) -> float | int:
        return f32(a + b) if self is Held.FLOAT else q_add(int(a), int(b))

    def mul(self, a: float | int, b: float | int) -> float | int:
        return f32(a * b) if self is Held.FLOAT else q_mul(int(a), int(b))


_COMPARE: dict[str, Callable[[float, float], bool]] = {
    ">=": lambda a, b: a >= b,
    "<": lambda a, b: a < b,
    "<=": lambda a, b: a <= b,
}


@dataclass(frozen=True)
class Violation:
    """Why a parameter set is refused."""

    names: tuple[str, ...]
    """The parameters concerned, the one to blame first (a relation's lhs)."""
    problem: str
    """What is wrong, with the limit, in one line."""
    relation: bool
    """A relation fails (else a value is outside its own range)."""


def _range_problem(p: Limit, x: float) -> str:
    return f"must be within [{p.minimum:g}, {p.maximum:g}] {p.unit} ({p.why}), got {x:g}"


def violation(
    values: Mapping[str, float], ways: Iterable[Held] = tuple(Held), table: Table | None = None
) -> Violation | None:
    """The first reason the firmware would refuse the parameter set @p values
    (by table name; a held parameter missing takes its default), held in any
    of @p ways (by default every way a build may hold them); None when they
    all accept it. Ranges are checked first, in index order, then the
    relations in table order, as in ctl_params_verdict()."""
    t = table if table is not None else load_table()
    full = {p.name: float(values.get(p.name, p.default)) for p in t.params if p.held}
    for held in ways:
        v = {name: held.hold(x) for name, x in full.items()}
        for p in t.params:
            if not p.held:
                continue
            # NaN compares false: out of range, as in the firmware.
            if not held.constant(p.minimum) <= v[p.name] <= held.constant(p.maximum) or (
                p.choices and v[p.name] != int(v[p.name])
            ):
                return Violation((p.name,), _range_problem(p, full[p.name]), False)
        for r in t.relations:
            total = v[r.rhs[0]]
            for name in r.rhs[1:]:
                total = held.add(total, v[name])
            rhs = held.mul(total, held.constant(r.factor))
            if not _COMPARE[r.op](v[r.lhs], rhs):
                unit = t.by_name(r.lhs).unit
                value = r.factor * math.fsum(full[n] for n in r.rhs)
                rhs_text = r.text().split(f" {r.op} ", 1)[1]
                problem = (
                    f"{r.lhs} ({full[r.lhs]:g} {unit}) must be {r.op} {rhs_text} "
                    f"({value:g} {unit}): {r.why}"
                )
                if held is not Held.FLOAT:
                    problem += f" (as the firmware holds them: {held.value})"
                return Violation((r.lhs, *r.rhs), problem, True)
    return None
