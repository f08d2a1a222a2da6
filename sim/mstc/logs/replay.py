# SPDX-License-Identifier: MIT
"""Replay a bus log through the in-process firmware and compare what it sends.

The firmware is deterministic in lock-step: what it sends depends only on the
frames it receives (time comes in STEP frames). So a log recorded from a run
(``make sim``'s bus.log, or candump on the bench) can be fed back, input frame
by input frame in the log's order, to a fresh instance of a firmware build,
and every frame that build sends compared with the frame recorded at the same
place:

- **input frames** are the identifiers the DBC says the ``FW`` node receives;
  each is handed to the firmware, which handles it at once (hal/sil);
- after each input, what the firmware sent is compared, in order, with the
  recorded frames of the identifiers ``FW`` sends that follow that input in
  the log up to the next input (its *window*).

Within a window, frames are paired by identifier sequence (a window whose
identifiers match pairs them in order; one whose identifiers differ is
aligned with :mod:`difflib`): a pair whose bytes differ *differs*, a recorded
frame without a partner is *missing*, a sent frame without one is *extra*.

The loop does as little as it can per frame: the log is packed into the C
frame layout once, the firmware's entry points of ``hal/sil/mstc_sil.h`` are
called through ctypes with addresses into that buffer, what it sends lands in
another buffer, and both are compared as byte arrays at the end; frames are
decoded with the DBC only for the report of a difference.
"""

from __future__ import annotations

import ctypes
import difflib
import errno
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import can
import numpy as np
from cantools.database.can import Database, Message

from mstc.can.dbc import E2E_SIGNALS, short_name, signal_values
from mstc.can.library import FRAME_DATA, FrameStruct, Library
from mstc.can.silbus import SilBus
from mstc.errors import FirmwareError
from mstc.logs.framelog import FrameLog, LogFrame, where_in
from mstc.model import Progress

FW_NODE = "FW"
"""The firmware's node in the DBC."""

MAX_DECODED = 20_000
"""Differing frames decoded for the statistics by message (the rest are counted)."""


_SIZE = ctypes.sizeof(FrameStruct)
"""Bytes of one frame in the C layout (16, with padding)."""
_ID = FrameStruct.id.offset
"""Offset of the identifier (a uint32 in the host's byte order)."""
_DLC = FrameStruct.dlc.offset
"""Offset of the length byte."""
_DATA = FrameStruct.data.offset
"""Offset of the data bytes (5)."""
_KEY = _DATA + FRAME_DATA
"""The bytes that matter: identifier, length, data; the padding after is undefined."""


def firmware_ids(db: Database) -> tuple[frozenset[int], frozenset[int]]:
    """The identifiers the firmware receives and those it sends, by the DBC.

    An identifier in both (none in mstc.dbc) counts as received.
    """
    inputs = frozenset(m.frame_id for m in db.messages if FW_NODE in m.receivers)
    outputs = frozenset(m.frame_id for m in db.messages if FW_NODE in m.senders) - inputs
    return inputs, outputs


def pack_frames(log: FrameLog, rows: np.ndarray) -> np.ndarray:
    """Rows of @p log in the C layout of ``mstc_sil_frame_t``: (len(rows), 16) uint8."""
    out = np.zeros((len(rows), _SIZE), dtype=np.uint8)
    out[:, _ID : _ID + 4] = log.frame_id[rows].astype(np.uint32).view(np.uint8).reshape(-1, 4)
    out[:, _DLC] = log.dlc[rows]
    out[:, _DATA:_KEY] = log.data[rows]
    return out


# ------------------------------------------------------------------ firmware


class SilFirmware:
    """A fresh instance of the in-process firmware, fed raw frames.

    The instance is restarted, and the library checked, by opening a
    :class:`~mstc.can.silbus.SilBus` on it; frames then go through the same C
    entry points (``mstc_sil_fw_send`` / ``mstc_sil_fw_recv``, one firmware per
    loaded library) without a :class:`can.Message` per frame.

    :param lib: path of ``libmstc_sil.so``.
    :param key: the key the log's commands were authenticated with (default:
        :func:`mstc.can.secoc.load_key`).
    :param session: the session the log's firmware drew at its start
        (:func:`recorded_session`), so that its commands verify again; None:
        one of its own, as any start.
    :raises FirmwareError: the library cannot be loaded or the firmware started.
    """

    def __init__(self, lib: Path, key: bytes | None = None, session: int | None = None) -> None:
        try:
            self.bus = SilBus(lib=str(lib), key=key, session=session)
        except can.CanError as exc:
            raise FirmwareError(str(exc)) from exc
        self.lib = lib
        self.numeric = self.bus.numeric
        # The library SilBus opened (one per process: one firmware instance),
        # its entry points taking addresses into the frame buffers below.
        library = Library.open(lib)
        self._send = library.address_function("mstc_sil_fw_send")
        self._recv = library.address_function("mstc_sil_fw_recv")

    def close(self) -> None:
        """Release the bus."""
        self.bus.shutdown()

    def __enter__(self) -> SilFirmware:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def run(
        self,
        packets: np.ndarray,
        expected: int = 0,
        progress: Progress | None = None,
    ) -> tuple[np.ndarray, np.ndarray, list[tuple[int, int]]]:
        """Feed @p packets in order, collecting what the firmware sends after each.

        :param packets: (n, 16) uint8 frames in the C layout (:func:`pack_frames`).
        :param expected: frames the firmware is expected to send (buffer size hint).
        :param progress: told how many packets are done, now and then.
        :returns: ``counts``: (n + 1,) frames sent before the first packet (at
            start) and after each packet; ``sent``: (sum(counts), 16) uint8 the
            frames sent, in order; ``refused``: (packet index, return code) of
            packets the library refused (bad identifier or length, full queue).
        """
        n = len(packets)
        source = ctypes.create_string_buffer(np.ascontiguousarray(packets).tobytes(), n * _SIZE)
        capacity = max(expected + 64, 256)
        sink = ctypes.create_string_buffer(capacity * _SIZE)
        base = ctypes.addressof(sink)
        end = base + capacity * _SIZE
        send, recv = self._send, self._recv
        counts = [0] * (n + 1)
        refused: list[tuple[int, int]] = []

        def grow(at: int) -> tuple[int, int, int]:
            """A sink twice as large; returns (new base, new end, where ``at`` is now)."""
            nonlocal sink, capacity
            used = at - ctypes.addressof(sink)
            bigger = ctypes.create_string_buffer(2 * capacity * _SIZE)
            ctypes.memmove(bigger, sink, used)
            sink, capacity = bigger, 2 * capacity
            new_base = ctypes.addressof(sink)
            return new_base, new_base + capacity * _SIZE, new_base + used

        out = base
        while recv(out) == 0:  # anything sent at start, before any input
            out += _SIZE
            if out == end:
                base, end, out = grow(out)
        counts[0] = (out - base) // _SIZE

        address = ctypes.addressof(source)
        tick = max(n // 200, 1)
        next_tick = tick
        for j in range(n):
            rc = send(address)
            address += _SIZE
            if rc:
                refused.append((j, rc))
            first = out
            while recv(out) == 0:
                out += _SIZE
                if out == end:
                    shift = out - first
                    base, end, out = grow(out)
                    first = out - shift
            counts[j + 1] = (out - first) // _SIZE
            if j == next_tick:
                next_tick += tick
                if progress is not None:
                    progress.update(j)
        used = out - base
        # numpy's stubs omit ctypes arrays, which numpy reads as buffers.
        flat = np.frombuffer(sink, dtype=np.uint8, count=used)  # type: ignore[call-overload]
        sent = flat.reshape(-1, _SIZE).copy()
        return np.array(counts, dtype=np.int64), sent, refused


# ---------------------------------------------------------------- comparing


@dataclass(frozen=True)
class Difference:
    """A place where the replayed firmware and the log disagree."""

    kind: str
    """``"differs"`` (same message, other bytes), ``"missing"`` (recorded, not
    sent) or ``"extra"`` (sent, not recorded)."""
    time: float
    """The recorded frame's time stamp, or for an extra frame the time of the
    input it answers [s]."""
    recorded: LogFrame | None
    """The frame in the log (None for an extra frame)."""
    sent: tuple[int, bytes] | None
    """Identifier and data the replayed firmware sent (None when missing)."""
    answering: LogFrame | None
    """The input frame the window follows (None: before the first input)."""
    next_input: LogFrame | None
    """The input frame that ends the window (None: the end of the log)."""


@dataclass
class MessageStats:
    """Comparisons of one message."""

    frame_id: int
    name: str
    compared: int = 0
    """Recorded frames paired with a sent one."""
    differing: int = 0
    missing: int = 0
    extra: int = 0
    max_delta: dict[str, float] = field(default_factory=dict)
    """Largest |sent − recorded| of each signal that differed (physical units),
    E2E fields left out, over the first :data:`MAX_DECODED` differing frames."""


@dataclass
class ReplayResult:
    """What a replay found."""

    log: FrameLog
    lib: Path
    numeric: str
    """The build's numeric mode (``float`` or ``fixed``)."""
    fed: int = 0
    """Input frames handed to the firmware."""
    not_fed: int = 0
    """Frames of identifiers the DBC does not have (or extended ones)."""
    recorded: int = 0
    """Frames of identifiers the firmware sends, in the log."""
    sent: int = 0
    """Frames the replayed firmware sent."""
    compared: int = 0
    matched: int = 0
    differing: int = 0
    missing: int = 0
    extra: int = 0
    refused: list[tuple[LogFrame, int]] = field(default_factory=list)
    """Input frames the library refused, with its return code."""
    auth_refused: tuple[int, int] = (0, 0)
    """Authenticated commands refused (the last AUTH_STATUS_refused): by the
    firmware of the log, and by the replayed firmware. More in the replay:
    it has another key than the log's firmware had."""
    first: Difference | None = None
    """The earliest difference in log order."""
    messages: list[MessageStats] = field(default_factory=list)
    """By identifier, the messages with any difference."""
    seconds: float = 0.0
    """Wall time of the replay, reading the log excluded [s]."""

    @property
    def identical(self) -> bool:
        """Every recorded frame was sent, bit for bit, and nothing else."""
        return not (self.differing or self.missing or self.extra or self.refused)

    @property
    def nothing_compared(self) -> bool:
        """Identical, but only because there was nothing to compare: the log
        holds no frame of the firmware's and the firmware sent none (a log of
        another bus, or of inputs the firmware does not answer). ``mstc
        replay`` fails on it unless told it is expected."""
        return self.identical and self.compared == 0

    @property
    def verdict(self) -> str:
        """``bit-exact``, ``DIFFERENT`` or ``nothing compared``."""
        if not self.identical:
            return "DIFFERENT"
        return "nothing compared" if self.nothing_compared else "bit-exact"


def _windows(input_rows: np.ndarray, output_rows: np.ndarray) -> np.ndarray:
    """The window of each output row: 0 before the first input, j after input j-1."""
    return np.searchsorted(input_rows, output_rows)


def _ids(packed: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(packed[:, _ID : _ID + 4]).view(np.uint32).ravel().astype(np.int64)


def _payload(packed_row: np.ndarray) -> tuple[int, bytes]:
    frame_id = int(np.ascontiguousarray(packed_row[_ID : _ID + 4]).view(np.uint32)[0])
    return frame_id, packed_row[_DATA : _DATA + int(packed_row[_DLC])].tobytes()


def decode_signals(
    db: Database, frame_id: int, data: bytes, *, choices: bool = True
) -> dict[str, float | int | str] | str:
    """A frame's signals by short name (without the message prefix), or why it
    cannot be decoded."""
    try:
        message = db.get_message_by_frame_id(frame_id)
    except KeyError:
        return f"identifier {frame_id:03X} is not in the DBC"
    try:
        return dict(signal_values(message, data, choices=choices))
    except Exception as exc:  # cantools raises several kinds on bad data
        return f"cannot decode: {exc}"


def message_name(db: Database, frame_id: int) -> str:
    """``0x181 STATUS``, or ``0x7FF (not in the DBC)``."""
    try:
        return f"0x{frame_id:03X} {db.get_message_by_frame_id(frame_id).name}"
    except KeyError:
        return f"0x{frame_id:03X} (not in the DBC)"


def compare(
    log: FrameLog,
    db: Database,
    input_rows: np.ndarray,
    output_rows: np.ndarray,
    counts: np.ndarray,
    sent: np.ndarray,
    result: ReplayResult,
) -> None:
    """Pair the recorded output frames with the sent ones, window by window,
    and fill @p result's counts, first difference and statistics."""
    n_in = len(input_rows)
    windows = n_in + 1
    expected = pack_frames(log, output_rows)
    ce = np.bincount(_windows(input_rows, output_rows), minlength=windows)
    ca = counts
    result.recorded, result.sent = len(output_rows), len(sent)
    exp_key, act_key = expected[:, :_KEY], sent[:, :_KEY]
    if np.array_equal(ce, ca) and np.array_equal(exp_key, act_key):
        result.compared = result.matched = len(output_rows)
        return

    es = np.cumsum(ce) - ce
    sa = np.cumsum(ca) - ca
    exp_id = log.frame_id[output_rows]
    act_id = _ids(sent)
    # Windows with as many frames on both sides pair them in order...
    m = np.where(ce == ca, ce, 0)
    w_of = np.repeat(np.arange(windows), m)
    k = np.arange(int(m.sum())) - np.repeat(np.cumsum(m) - m, m)
    ei, ai = es[w_of] + k, sa[w_of] + k
    # ...when their identifiers agree; the others are aligned by identifier.
    irregular = np.union1d(np.flatnonzero(ce != ca), w_of[exp_id[ei] != act_id[ai]])
    keep = ~np.isin(w_of, irregular)
    pair_e, pair_a = [ei[keep]], [ai[keep]]
    missing: list[int] = []
    extra: list[tuple[int, float, int]] = []  # (sent index, log position, window)

    def end_of(w: int) -> float:
        """Log position just before the input that ends window w."""
        return float(input_rows[w] if w < n_in else len(log)) - 0.5

    for w in irregular.tolist():
        e0, a0 = int(es[w]), int(sa[w])
        e_ids = exp_id[e0 : e0 + ce[w]].tolist()
        a_ids = act_id[a0 : a0 + ca[w]].tolist()
        matcher = difflib.SequenceMatcher(None, e_ids, a_ids, autojunk=False)
        for tag, i1, i2, j1, j2 in matcher.get_opcodes():
            if tag == "equal":
                pair_e.append(np.arange(e0 + i1, e0 + i2))
                pair_a.append(np.arange(a0 + j1, a0 + j2))
                continue
            missing.extend(range(e0 + i1, e0 + i2))
            at = float(output_rows[e0 + i1]) - 0.5 if i1 < len(e_ids) else end_of(w)
            extra.extend((a0 + j, at, w) for j in range(j1, j2))

    pe = np.concatenate(pair_e).astype(np.int64)
    pa = np.concatenate(pair_a).astype(np.int64)
    order = np.argsort(pe, kind="stable")
    pe, pa = pe[order], pa[order]
    differ = (exp_key[pe] != act_key[pa]).any(axis=1)
    result.compared = len(pe)
    result.differing = int(differ.sum())
    result.matched = result.compared - result.differing
    result.missing = len(missing)
    result.extra = len(extra)

    # The first difference in log order.
    candidates: list[tuple[float, str, int]] = []
    if result.differing:
        first_pair = int(np.flatnonzero(differ)[0])
        candidates.append((float(output_rows[pe[first_pair]]), "differs", first_pair))
    if missing:
        candidates.append((float(output_rows[min(missing)]), "missing", min(missing)))
    if extra:
        best = min(range(len(extra)), key=lambda i: (extra[i][1], extra[i][0]))
        candidates.append((extra[best][1], "extra", best))
    if candidates:
        _, kind, index = min(candidates)
        result.first = _difference(
            log, input_rows, output_rows, sent, kind, index, pe, pa, missing, extra
        )

    # Statistics by message.
    stats: dict[int, MessageStats] = {}

    def entry(frame_id: int) -> MessageStats:
        if frame_id not in stats:
            name = message_name(db, frame_id).split(" ", 1)[1]
            stats[frame_id] = MessageStats(frame_id, name)
        return stats[frame_id]

    ids, n = np.unique(exp_id[pe], return_counts=True)
    for frame_id, count in zip(ids.tolist(), n.tolist(), strict=True):
        entry(frame_id).compared = count
    for i in missing:
        entry(int(exp_id[i])).missing += 1
    for j, _, _ in extra:
        entry(int(act_id[j])).extra += 1
    for p in np.flatnonzero(differ)[:MAX_DECODED].tolist():
        s = entry(int(exp_id[pe[p]]))
        recorded = decode_signals(db, *_payload(expected[pe[p]]), choices=False)
        actual = decode_signals(db, *_payload(sent[pa[p]]), choices=False)
        if isinstance(recorded, str) or isinstance(actual, str):
            continue
        for name, value in recorded.items():
            other = actual.get(name)
            # The E2E fields differ whenever anything else does: left out.
            if name in E2E_SIGNALS or other is None or other == value:
                continue
            delta = abs(float(other) - float(value))
            s.max_delta[name] = max(s.max_delta.get(name, 0.0), delta)
    for p in np.flatnonzero(differ).tolist():
        entry(int(exp_id[pe[p]])).differing += 1
    result.messages = [s for _, s in sorted(stats.items()) if s.differing or s.missing or s.extra]


def _difference(
    log: FrameLog,
    input_rows: np.ndarray,
    output_rows: np.ndarray,
    sent: np.ndarray,
    kind: str,
    index: int,
    pe: np.ndarray,
    pa: np.ndarray,
    missing: list[int],
    extra: list[tuple[int, float, int]],
) -> Difference:
    """The :class:`Difference` of one pair (differs), missing frame or extra frame."""

    def inputs_around(w: int) -> tuple[LogFrame | None, LogFrame | None]:
        before = log.frame(int(input_rows[w - 1])) if w > 0 else None
        after = log.frame(int(input_rows[w])) if w < len(input_rows) else None
        return before, after

    if kind == "extra":
        j, _, w = extra[index]
        before, after = inputs_around(w)
        t = before.timestamp if before is not None else float(log.time[0])
        return Difference("extra", t, None, _payload(sent[j]), before, after)
    e = int(pe[index]) if kind == "differs" else index
    row = int(output_rows[e])
    w = int(np.searchsorted(input_rows, row))
    before, after = inputs_around(w)
    actual = _payload(sent[int(pa[index])]) if kind == "differs" else None
    return Difference(kind, float(log.time[row]), log.frame(row), actual, before, after)


def recorded_session(log: FrameLog, db: Database) -> int | None:
    """The session the firmware of @p log drew at its start: AUTH_STATUS_session
    of the first AUTH_STATUS it sent; None when it sent none."""
    message = db.get_message_by_name("AUTH_STATUS")
    rows = np.flatnonzero(log.standard_ids_in([message.frame_id]))
    if len(rows) == 0:
        return None
    row = int(rows[0])
    signals = decode_signals(
        db, message.frame_id, bytes(log.data[row][: int(log.dlc[row])]), choices=False
    )
    return int(signals["session"]) if isinstance(signals, dict) else None


def _refused(db: Database, data: bytes | None) -> int:
    """AUTH_STATUS_refused of an AUTH_STATUS payload @p data; 0 for None."""
    if data is None:
        return 0
    signals = decode_signals(
        db, db.get_message_by_name("AUTH_STATUS").frame_id, data, choices=False
    )
    return int(signals["refused"]) if isinstance(signals, dict) else 0


def replay(
    log: FrameLog,
    db: Database,
    lib: Path,
    *,
    progress: Callable[[int], Progress] | None = None,
    key: bytes | None = None,
) -> ReplayResult:
    """Replay @p log through a fresh instance of the firmware in @p lib and
    compare what it sends with what the log recorded.

    :param log: the log (:func:`mstc.logs.read.read_log`).
    :param db: the DBC: which identifiers are inputs and outputs, and decoding.
    :param lib: ``libmstc_sil.so`` of the build to check.
    :param progress: makes a :class:`Progress` for a number of input frames.
    :param key: the key the log was recorded with: its authenticated commands
        replay only under it (default: :func:`mstc.can.secoc.load_key`).
    :raises FirmwareError: the library cannot be loaded or started.
    """
    inputs, outputs = firmware_ids(db)
    is_input = log.standard_ids_in(inputs)
    is_output = log.standard_ids_in(outputs)
    input_rows = np.flatnonzero(is_input)
    output_rows = np.flatnonzero(is_output)
    start = time.perf_counter()
    bar = progress(len(input_rows)) if progress is not None else None
    # The firmware of the log drew its session at its start; a fresh one
    # draws another, under which the log's commands (signed for the old one)
    # are refused, as after any restart: the replay starts it in the log's.
    with SilFirmware(lib, key, recorded_session(log, db)) as fw:
        result = ReplayResult(log=log, lib=lib, numeric=fw.numeric)
        counts, sent, refused = fw.run(pack_frames(log, input_rows), len(output_rows), bar)
    if bar is not None:
        bar.close()
    known = log.standard_ids_in(m.frame_id for m in db.messages)
    result.fed = len(input_rows)
    result.not_fed = int((~known).sum())
    result.refused = [(log.frame(int(input_rows[j])), rc) for j, rc in refused]
    compare(log, db, input_rows, output_rows, counts, sent, result)
    # The last AUTH_STATUS each side sent (found on the arrays: the firmware
    # sends one frame in three or so, and a loop over them in Python took a
    # third of the replay's time).
    auth_id = db.get_message_by_name("AUTH_STATUS").frame_id
    logged = np.flatnonzero(log.standard_ids_in([auth_id]))
    own = np.flatnonzero(_ids(sent) == auth_id)
    last_logged = bytes(log.data[logged[-1]][: int(log.dlc[logged[-1]])]) if len(logged) else None
    last_own = _payload(sent[own[-1]])[1] if len(own) else None
    result.auth_refused = (_refused(db, last_logged), _refused(db, last_own))
    result.seconds = time.perf_counter() - start
    return result


# ------------------------------------------------------------------ reports


def _hex(data: bytes) -> str:
    return " ".join(f"{b:02X}" for b in data) if data else "(no data)"


def _value_text(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.9g}"
    return str(value)


def _signal_table(
    db: Database, frame_id: int, recorded: bytes | None, sent: bytes | None
) -> list[str]:
    """Signal by signal, recorded beside sent, differing ones marked with *."""
    try:
        message: Message | None = db.get_message_by_frame_id(frame_id)
    except KeyError:
        message = None
    columns = []
    for data in (recorded, sent):
        columns.append(None if data is None else decode_signals(db, frame_id, data))
    lines = []
    for label, col in zip(("recorded", "sent"), columns, strict=True):
        if isinstance(col, str):
            lines.append(f"    ({label}: {col})")
    if message is None:
        return lines
    rows = [("signal", "recorded", "sent", "unit", "")]
    for signal in message.signals:
        name = short_name(message, signal.name)
        cells = [
            _value_text(c[name]) if isinstance(c, dict) and name in c else "—" for c in columns
        ]
        both = all(isinstance(c, dict) for c in columns)
        mark = "*" if both and cells[0] != cells[1] else ""
        rows.append((name, cells[0], cells[1], signal.unit or "", mark))
    width = [max(len(r[i]) for r in rows) for i in range(4)]
    for r in rows:
        lines.append(
            f"    {r[0]:<{width[0]}}  {r[1]:>{width[1]}}  {r[2]:>{width[2]}}  "
            f"{r[3]:<{width[3]}}  {r[4]}".rstrip()
        )
    return lines


def format_difference(diff: Difference, log: FrameLog, db: Database) -> str:
    """The report of one difference: where, what, bytes and signals."""
    lines = []
    if diff.recorded is not None:
        row_where = where_in(log, diff.recorded.line)
        name = message_name(db, diff.recorded.frame_id)
    else:
        assert diff.sent is not None
        row_where = f"{log.path}: after " + (
            f"line {diff.answering.line}" if diff.answering is not None else "the start"
        )
        name = message_name(db, diff.sent[0])
    what = {
        "differs": "the firmware sent other bytes",
        "missing": "recorded, but the firmware did not send it",
        "extra": "sent by the firmware, but not in the log",
    }[diff.kind]
    lines.append(f"first difference: {row_where}, t = {diff.time:.6f} s: {name}: {what}")
    if diff.answering is not None:
        a = diff.answering
        lines.append(
            f"  answering line {a.line}: {message_name(db, a.frame_id)} "
            f"{_hex(a.data)} (t = {a.timestamp:.6f} s)"
        )
    else:
        lines.append("  before the first input frame: a fresh firmware has sent nothing yet")
    if diff.next_input is not None and diff.kind != "differs":
        lines.append(f"  window ends at line {diff.next_input.line} (the next input frame)")
    recorded = diff.recorded.data if diff.recorded is not None else None
    sent = diff.sent[1] if diff.sent is not None else None
    lines.append(f"  recorded  {_hex(recorded) if recorded is not None else '—'}")
    lines.append(f"  sent      {_hex(sent) if sent is not None else '—'}")
    if diff.recorded is not None:
        frame_id = diff.recorded.frame_id
    else:
        assert diff.sent is not None  # an extra frame: what was sent
        frame_id = diff.sent[0]
    lines += _signal_table(db, frame_id, recorded, sent)
    return "\n".join(lines)


def _delta_text(db: Database, stats: MessageStats) -> str:
    if not stats.max_delta:
        return ""
    try:
        message = db.get_message_by_frame_id(stats.frame_id)
        units = {short_name(message, s.name): s.unit or "" for s in message.signals}
    except KeyError:
        units = {}
    parts = [
        f"{name} {delta:.3g}{(' ' + units[name]) if units.get(name) else ''}"
        for name, delta in sorted(stats.max_delta.items(), key=lambda kv: -kv[1])
    ]
    return ", ".join(parts)


def format_summary(result: ReplayResult, db: Database) -> str:
    """The summary printed after a replay."""
    log = result.log
    unit = "records" if log.format == "blf" else "lines"
    rate = len(log) / result.seconds if result.seconds > 0 else 0.0
    lines = [
        f"replay: {log.path} ({log.format}, {log.lines:,} {unit}, {len(log):,} frames, "
        f"{log.duration:.3f} s)",
        f"  firmware            {result.lib} ({result.numeric})",
        f"  fed                 {result.fed:>8,}  input frames (FW receives them in the DBC)",
        f"  not fed             {result.not_fed:>8,}  identifiers not in the DBC",
        f"  recorded from FW    {result.recorded:>8,}",
        f"  sent by FW          {result.sent:>8,}",
        f"  compared            {result.compared:>8,}  matched {result.matched:,}, "
        f"differing {result.differing:,}",
        f"  missing             {result.missing:>8,}  recorded, not sent",
        f"  extra               {result.extra:>8,}  sent, not recorded",
        f"  log problems        {log.problems.total:>8,}",
    ]
    for frame, rc in result.refused[:5]:
        lines.append(
            f"  refused             line {frame.line}: {message_name(db, frame.frame_id)} "
            f"({errno.errorcode.get(-rc, rc)})"
        )
    if result.messages:
        lines.append("  differences by message:")
        name_w = max(len(f"0x{s.frame_id:03X} {s.name}") for s in result.messages)
        lines.append(f"    {'message':<{name_w}}  compared  differing  missing  extra  largest |Δ|")
        for s in result.messages:
            label = f"0x{s.frame_id:03X} {s.name}"
            lines.append(
                f"    {label:<{name_w}}  {s.compared:>8,}  {s.differing:>9,}  {s.missing:>7,}  "
                f"{s.extra:>5,}  {_delta_text(db, s)}".rstrip()
            )
    lines.append(
        f"  result              {result.verdict} ({result.seconds:.2f} s, {rate:,.0f} frames/s)"
    )
    return "\n".join(lines)
