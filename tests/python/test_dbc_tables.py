# SPDX-License-Identifier: MIT
"""The DBC is the Python side's only source of wire numbers (mstc.can.dbc).

Each test edits a copy of firmware/comm/mstc.dbc and shows what the Python
side does with it. What "follows" means, table by table:

- PARAM_SET/GET/VALUE_index: a renumbered parameter is written with its new
  index (CanController) and read back under its name (decode_log); a renamed
  one that :data:`mstc.model.PARAM_NAMES` names is a DbcError naming the DBC,
  the table and the entry, before anything is sent.
- STATUS_mode, EVENT_kind, STATUS_side/EVENT_side: a renumbered entry is
  decoded into the same :class:`~mstc.model.Mode`, EventKind or Side; a
  renamed one that an enum member names is a DbcError.
- PARAM_VALUE_result ``ok`` and PARAM index ``arm``: same as the parameters.
- Entries the code does not name (STATUS_halt reasons, HEARTBEAT states):
  renamed ones appear under their new name wherever names are shown
  (status.csv columns of decode_log).

Expected values come from the edited DBC read by cantools and from the raw
bytes of the frames, never from the tables under test.
"""

from __future__ import annotations

import re
from pathlib import Path

import can
import cantools
import pytest

from logfiles import DATA, DBC
from mstc.can import secoc
from mstc.can.dbc import load_database, tables
from mstc.can.protocol import Protocol
from mstc.cli import main
from mstc.errors import DbcError
from mstc.logs.decode import decode_log
from mstc.logs.read import read_log
from mstc.loop.lockstep import CanController
from mstc.model import PARAM_NAMES, Event, EventKind, Mode, Params, Side


def edited_dbc(tmp_path: Path, *edits: tuple[str, str]) -> Path:
    """A copy of the DBC with each (regular expression, replacement) applied;
    each must change something."""
    text = DBC.read_text()
    for pattern, replacement in edits:
        text, n = re.subn(pattern, replacement, text)
        assert n, f"{pattern!r} matches nothing in {DBC}"
    path = tmp_path / "edited.dbc"
    path.write_text(text)
    return path


def renumber_param(name: str, old: int, new: int) -> tuple[str, str]:
    """The edit that moves parameter @p name from index @p old to @p new in all
    three index tables."""
    return (rf'(VAL_ \d+ PARAM_\w+_index .*?) {old} "{name}"', rf'\1 {new} "{name}"')


TEST_KEY = bytes.fromhex("2b7e151628aed2a6abf7158809cf4f3c")
"""RFC 4493's example key, also tests/data/test.key."""


class AnsweringFirmware(can.BusABC):
    """A bus whose far end accepts every command: a PARAM_SET is answered,
    once its PARAM_AUTH follows, with PARAM_VALUE (same index, result ``ok``,
    the value) and the status (AUTH_STATUS, AUTH_CHALLENGE: the freshness it
    carried, accepted, authenticated under TEST_KEY), encoded with @p dbc; a
    PARAM_GET with PARAM_VALUE and the status at freshness 0. No command MAC
    is checked: what is under test is which index the tools write."""

    def __init__(self, dbc: Path) -> None:
        self.fw = Protocol(node=None, dbc_path=dbc)
        self.sent: list[can.Message] = []
        self.pending: list[can.Message] = []
        self.waiting: dict[str, float | int | str] | None = None
        super().__init__(channel="answering")

    def _answer(self, index: float | int | str, value: float | int | str, freshness: int) -> None:
        enc = self.fw.encode
        status = secoc.Status(session=1, freshness=freshness, last=0, refused=0, saturated=False)
        mac = int.from_bytes(secoc.status_mac(TEST_KEY, status), "little")
        self.pending.append(enc("PARAM_VALUE", index=index, result="ok", value=value))
        self.pending.append(
            enc("AUTH_STATUS", last="ok", session=1, refused=0, refused_saturated=0)
        )
        self.pending.append(enc("AUTH_CHALLENGE", freshness=freshness, mac=mac))

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self.sent.append(msg)
        frame = self.fw.decode(msg)
        if frame.name == "PARAM_GET":
            self._answer(frame.signals["index"], 0.0, 0)
        elif frame.name == "PARAM_SET":
            self.waiting = frame.signals
        elif frame.name == "PARAM_AUTH" and self.waiting is not None:
            s, self.waiting = self.waiting, None
            self._answer(s["index"], s["value"], int(frame.signals["freshness"]))

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        return (self.pending.pop(0) if self.pending else None), False


def test_a_renumbered_parameter_is_written_with_its_new_index(tmp_path: Path) -> None:
    dbc = edited_dbc(tmp_path, renumber_param("D_s", 4, 40))
    raw = cantools.database.load_file(dbc)
    assert (
        raw.get_message_by_name("PARAM_SET").get_signal_by_name("PARAM_SET_index").choices[40]
        == "D_s"
    )
    with AnsweringFirmware(dbc) as bus:
        CanController(
            bus, Params(d_s=0.3), protocol=Protocol(node=None, dbc_path=dbc), key=TEST_KEY
        )
    param_sets = [m for m in bus.sent if m.arbitration_id == 0x120]
    # Byte 2 is PARAM_SET_index (bits 16..23 in the DBC), read by hand.
    by_index = {m.data[2]: raw.decode_message(0x120, m.data)["PARAM_SET_value"] for m in param_sets}
    assert by_index[40] == pytest.approx(0.3)
    assert 4 not in by_index
    # Every parameter of Params, and the strategy (index 14, value 1 "mstc").
    assert len(by_index) == len(PARAM_NAMES) + 1
    assert by_index[14] == 1.0


def test_a_renumbered_parameter_is_read_back_under_its_name(tmp_path: Path) -> None:
    # The committed log answers R_ob with index 1; a DBC that gives index 1 to
    # R_m instead reads the log's R_ob value as R_m, and the other way round.
    swap = (r'(VAL_ \d+ PARAM_\w+_index) 0 "R_m" 1 "R_ob"', r'\1 0 "R_ob" 1 "R_m"')
    dbc = edited_dbc(tmp_path, swap)
    db = load_database(dbc)
    decoded = decode_log(read_log(DATA / "paper-line.log", db), db)
    usual = decode_log(read_log(DATA / "paper-line.log", load_database()), load_database())
    assert (decoded.params.r_m, decoded.params.r_ob) == (usual.params.r_ob, usual.params.r_m)
    assert usual.params.r_m != usual.params.r_ob


def frame_line(proto: Protocol, t: float, name: str, **signals: object) -> str:
    msg = proto.encode(name, signals)  # type: ignore[arg-type]  # values of mixed types
    return f"({t:.6f}) sil0 {msg.arbitration_id:03X}#{bytes(msg.data).hex().upper()}"


def test_renumbered_modes_kinds_and_sides_decode_to_the_same_members(tmp_path: Path) -> None:
    dbc = edited_dbc(
        tmp_path,
        (r'STATUS_mode 0 "track" 1 "avoid" 2 "stop"', 'STATUS_mode 0 "stop" 1 "track" 2 "avoid"'),
        (r'EVENT_kind 1 "detect" 2 "activate"', 'EVENT_kind 1 "activate" 2 "detect"'),
        (
            r'(STATUS|EVENT)_side 0 "none" 1 "left" 2 "right"',
            r'\1_side 0 "none" 1 "right" 2 "left"',
        ),
    )
    proto = Protocol(node=None, dbc_path=dbc)
    lines = [
        frame_line(proto, 0.0, "STEP", step=0, time=0.5),
        frame_line(proto, 0.0, "ODOM_XY", x=1.0, y=2.0),
        frame_line(proto, 0.0, "ODOM_THETA", theta=0.0),
        frame_line(proto, 0.0, "REF_XY", x=1.0, y=2.0),
        frame_line(proto, 0.0, "REF_MOTION", theta=0.0, v=0.5, w=0.0),
        frame_line(proto, 0.0, "EVENT", kind="activate", side="right", obstacle=1, time=0.5),
        frame_line(
            proto,
            0.0,
            "STATUS",
            mode="avoid",
            side="right",
            obstacle=1,
            faults=0,
            e=0.0,
            distance=1.0,
            step=0,
            halt="none",
        ),  # fmt: skip
        frame_line(proto, 0.0, "STATUS_TRK", odom_counter=0, e1=0.0, e2=0.0, e3=0.0),
        frame_line(proto, 0.0, "WHEEL_CMD", step=0, left=1.0, right=2.0),
    ]
    status = bytes.fromhex(lines[6].split("#")[1])
    event = bytes.fromhex(lines[5].split("#")[1])
    # By hand: mode is bits 12..13, side 14..15 of STATUS; EVENT kind 12..14, side 15..16.
    assert ((status[1] >> 4) & 3, status[1] >> 6) == (2, 1)
    assert ((event[1] >> 4) & 7, (event[1] >> 7) | ((event[2] & 1) << 1)) == (1, 1)
    log = tmp_path / "edited.log"
    log.write_text("\n".join(lines) + "\n")
    db = load_database(dbc)
    decoded = decode_log(read_log(log, db), db)
    assert decoded.trace.mode == (Mode.AVOID,)
    assert decoded.events == (Event(500_000, EventKind.ACTIVATE, 1, Side.RIGHT),)
    row = dict(zip(decoded.status_columns, decoded.status_rows[0], strict=True))
    assert (row["mode"], row["side"]) == ("avoid", "right")


@pytest.mark.parametrize(
    ("edit", "table", "entry"),
    [
        ((r'"R_m"', '"R_robot"'), "PARAM_SET_index", "R_m"),
        ((r'"arm"', '"enable"'), "PARAM_SET_index", "arm"),
        ((r'1 "avoid"', '1 "evade"'), "STATUS_mode", "avoid"),
        ((r'3 "complete"', '3 "done"'), "EVENT_kind", "complete"),
        ((r'((?:STATUS|EVENT)_side 0 "none" 1) "left"', r'\1 "port"'), "STATUS_side", "left"),
        ((r'0 "ok"', '0 "accepted"'), "PARAM_VALUE_result", "ok"),
    ],
)
def test_a_renamed_entry_the_code_names_is_a_clear_error(
    tmp_path: Path, edit: tuple[str, str], table: str, entry: str
) -> None:
    dbc = edited_dbc(tmp_path, edit)
    with pytest.raises(DbcError) as caught:
        tables(load_database(dbc))
    message = str(caught.value)
    assert str(dbc) in message and table in message and repr(entry) in message, message
    # Where the code needs it: nothing is sent, nothing decoded.
    with AnsweringFirmware(DBC) as bus, pytest.raises(DbcError, match=table):
        CanController(bus, Params(), protocol=Protocol(node=None, dbc_path=dbc))
    assert bus.sent == []


def test_index_tables_that_disagree_are_a_clear_error(tmp_path: Path) -> None:
    dbc = edited_dbc(tmp_path, (r'(VAL_ \d+ PARAM_GET_index .*?) 4 "D_s"', r'\1 4 "D_safe"'))
    with pytest.raises(DbcError, match=r"PARAM_GET_index: differs from PARAM_SET_index"):
        tables(load_database(dbc))


def test_the_command_line_names_the_missing_entry(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dbc = edited_dbc(tmp_path, (r'1 "avoid"', '1 "evade"'))
    rc = main(
        ["plot", "--dbc", str(dbc), "--out", str(tmp_path / "out"), str(DATA / "paper-line.log")]
    )
    err = capsys.readouterr().err
    assert rc == 2
    assert "STATUS_mode" in err and "'avoid'" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_a_renamed_entry_the_code_does_not_name_shows_under_its_new_name(tmp_path: Path) -> None:
    dbc = edited_dbc(tmp_path, (r'STATUS_halt 0 "none"', 'STATUS_halt 0 "clear"'))
    db = load_database(dbc)
    decoded = decode_log(read_log(DATA / "paper-line.log", db), db)
    halt = decoded.status_columns.index("halt")
    # The committed run never halts: every STATUS says halt 0.
    assert {row[halt] for row in decoded.status_rows} == {"clear"}
