# SPDX-License-Identifier: MIT
"""Decode a bus log into what a simulation reports: events, status, trace.

From the frames alone, with the DBC through cantools, so that a run recorded
on a real board is analysed exactly like a simulation:

- one row per control step, at each WHEEL_CMD: the step's time (from the STEP
  frame of the same step number; without STEP frames, the log's time stamp
  from the first WHEEL_CMD on), the latest odometry (ODOM_XY, ODOM_THETA) and
  reference (REF_XY, REF_MOTION) before it, the wheel speeds and from them the
  body velocity v = r (ω_R + ω_L)/2, ω = r (ω_R − ω_L)/L, and the latest
  STATUS and STATUS_TRK;
- the events of the EVENT frames;
- the obstacles of the OBSTACLE frames (each id at the mean of its reported
  positions: the paper's obstacles are static), and the distance from the
  robot to each at every step;
- the parameters of the PARAM_VALUE answers in the log (the firmware's own
  values), Table 1 of the paper for any not there.

Frames with a bad E2E CRC or of the wrong length are reported and not used;
alive counters are not checked (a log that lost frames still decodes). Like
the reader's, the decoder's problems are all counted and the first ones kept.
"""

from __future__ import annotations

import json
import math
import statistics
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
from cantools.database.can import Database, Message

from mstc.can.dbc import E2E_SIGNALS, e2e_data_ids, numeric_values, short_name, tables
from mstc.can.protocol import e2e_crc
from mstc.errors import LogError
from mstc.logs.framelog import (
    DEFAULT_MAX_PROBLEMS,
    MAX_TIME_S,
    FrameLog,
    LogProblem,
    ProblemKind,
    ProblemList,
)
from mstc.loop.result import TRACE_COLUMNS, Trace
from mstc.model import (
    PARAM_NAMES,
    Event,
    Fault,
    Mode,
    Obstacle,
    Params,
    Progress,
    with_param_values,
)

TIME_MODULO = 1 << 32
"""STEP and EVENT times [µs] wrap here."""

_INPUT_COLUMNS = ("x", "y", "theta", "x_r", "y_r", "theta_r", "v_r", "w_r")
_WHEEL_COLUMNS = ("wheel_left", "wheel_right", "v", "w")


def _float32_value(value: float) -> float:
    """The shortest decimal that is the same IEEE single: 0.2f gives 0.2."""
    return float(str(np.float32(value)))


@dataclass
class DecodedLog:
    """What a log says about a run."""

    log: FrameLog
    params: Params
    """Parameters: the log's PARAM_VALUE answers over Table 1."""
    params_from_log: tuple[str, ...]
    """Names (DBC value table) of the parameters the log gave."""
    obstacles: tuple[Obstacle, ...]
    """Every obstacle reported, by id."""
    trace: Trace
    """One row per control step, like a simulation's."""
    steps: np.ndarray
    """The step number of each row (WHEEL_CMD's)."""
    status_columns: tuple[str, ...]
    """Columns of :attr:`status_rows`."""
    status_rows: list[list[object]]
    """One row per control step: inputs, wheels, every STATUS and STATUS_TRK signal."""
    events: tuple[Event, ...]
    min_distance: tuple[float, ...]
    """Smallest centre distance to each obstacle over the rows [m]."""
    faults: dict[Fault, int]
    """Steps that reported each fault bit."""
    modes: dict[Mode, int]
    """Steps run in each mode."""
    counters: dict[str, int] = field(default_factory=dict)
    """The last STATUS_COUNTERS (frames the firmware dropped, by reason)."""
    problems: ProblemList = field(default_factory=ProblemList)
    """Frames not used (bad CRC, undecodable, a time stamp too far off): all
    counted, the first ones kept."""
    dt: float = 0.0
    """The median control period [s] (0 with fewer than two steps)."""
    stamps: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """The log's time stamp of each row's WHEEL_CMD [s]."""
    epoch_ns: int = 0
    """Wall-clock time of the log's time 0 [ns since 1970]: 0 for a log
    stamped in wall-clock time (a bus's), the run's start for a simulation's,
    whose stamps count from 0 (its folder's run.json; :func:`log_epoch`)."""

    def ns(self, seconds: float) -> int:
        """The wall-clock time [ns since 1970] of the log's time @p seconds."""
        return self.epoch_ns + round(seconds * 1e9)

    @property
    def name(self) -> str:
        """The name of its output folder: see :func:`output_name`."""
        return output_name(self.log.path)


RUN_FILE = "run.json"
"""The file of a run's folder that says when the run started (``mstc sim``,
``mstc hil``): ``{"started": ISO 8601 UTC, "started_ns": ns since 1970}``."""
_RELATIVE = 1e8
"""A log whose first time stamp is below this [s] (1973) counts from its
run's start, as a simulation's does; a bus's counts from 1970."""


def run_json(started_ns: int) -> str:
    """The text of a run's :data:`RUN_FILE`, for a run started at @p started_ns."""
    started = datetime.fromtimestamp(started_ns / 1e9, UTC).isoformat(timespec="microseconds")
    return json.dumps({"started": started.replace("+00:00", "Z"), "started_ns": started_ns}) + "\n"


def log_epoch(path: Path, first: float) -> int:
    """:attr:`DecodedLog.epoch_ns` of the log @p path whose first time stamp
    is @p first [s]: its run's start (the :data:`RUN_FILE` beside it) when it
    counts from 0, else 0 (stamped in wall-clock time, or no run's folder).

    :raises LogError: that file exists but does not say when the run started.
    """
    started = path.parent / RUN_FILE
    if first >= _RELATIVE or not started.is_file():
        return 0
    try:
        ns = json.loads(started.read_text())["started_ns"]
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError) as exc:
        raise LogError(f"{started}: cannot read the run's start: {exc}") from exc
    if type(ns) is not int or not 0 <= ns < 2**63:
        raise LogError(f"{started}: started_ns: expected ns since 1970, got {ns!r}")
    return ns


def output_name(path: Path) -> str:
    """The name a log's outputs go under: its file stem; for a run's
    ``bus.log``, its folder's name (``build/hil/paper-line/bus.log`` is
    ``paper-line``)."""
    return path.parent.name if path.stem == "bus" and path.parent.name else path.stem


class _Decoder:
    """Walks a log's frames in order, keeping the latest of each input."""

    def __init__(self, log: FrameLog, db: Database, max_problems: int) -> None:
        self.log = log
        self.db = db
        self.tables = tables(db)
        self.messages: dict[int, Message] = {m.frame_id: m for m in db.messages}
        self.data_ids = e2e_data_ids(db)
        self.latest: dict[str, dict[str, float | int]] = {}
        self.step_time: dict[int, int] = {}
        self.time_raw: int | None = None
        self.time_wraps = 0
        self.now_us: int | None = None
        self.obstacle_reports: dict[int, list[tuple[float, float, float]]] = {}
        self.param_values: dict[str, float] = {}
        self.events: list[Event] = []
        self.rows: list[dict[str, object]] = []
        self.problems = ProblemList(max_problems)
        self.first_wheel_time: float | None = None

    def signals(self, row: int, message: Message) -> dict[str, float | int] | None:
        """The frame's signals by short name, or None (a problem is recorded)."""
        log = self.log
        data = log.data[row, : int(log.dlc[row])].tobytes()
        where, line = log.where(row), int(log.line[row])
        if len(data) != message.length:
            return None  # reported by read_log
        data_id = self.data_ids.get(message.frame_id)
        if data_id is not None and data[0] != e2e_crc(data_id, data):
            self.problems.append(
                LogProblem(
                    where,
                    line,
                    ProblemKind.MALFORMED,
                    f"{message.name}: bad E2E CRC 0x{data[0]:02X}, want "
                    f"0x{e2e_crc(data_id, data):02X}: not used",
                )
            )
            return None
        try:
            values = numeric_values(message, data)
        except Exception as exc:  # cantools raises several kinds on bad data
            self.problems.append(
                LogProblem(where, line, ProblemKind.MALFORMED, f"{message.name}: {exc}")
            )
            return None
        return {k: v for k, v in values.items() if k not in E2E_SIGNALS}

    def run(self, progress: Progress | None = None) -> None:
        log = self.log
        tick = max(len(log) // 200, 1)
        for row in range(len(log)):
            if progress is not None and row % tick == 0:
                progress.update(row)
            if log.extended[row]:
                continue
            message = self.messages.get(int(log.frame_id[row]))
            if message is None:
                continue
            s = self.signals(row, message)
            if s is None:
                continue
            handler = getattr(self, f"on_{message.name.lower()}", None)
            if handler is not None:
                handler(row, s)
            else:
                self.latest[message.name] = s

    # Inputs ----------------------------------------------------------------

    def on_step(self, row: int, s: dict[str, float | int]) -> None:
        raw = round(float(s["time"]) * 1e6)
        if self.time_raw is not None and raw < self.time_raw:
            self.time_wraps += 1
        self.time_raw = raw
        self.now_us = (self.time_wraps << 32) | raw
        self.step_time[int(s["step"])] = self.now_us
        self.latest["STEP"] = s

    def on_obstacle(self, row: int, s: dict[str, float | int]) -> None:
        report = (float(s["x"]), float(s["y"]), float(s["radius"]))
        self.obstacle_reports.setdefault(int(s["id"]), []).append(report)

    # Outputs ---------------------------------------------------------------

    def on_param_value(self, row: int, s: dict[str, float | int]) -> None:
        if int(s["result"]) != self.tables.param_ok:
            return
        name = self.tables.param_index.name_of(int(s["index"]))
        if name is not None:
            self.param_values[name] = _float32_value(float(s["value"]))

    def on_event(self, row: int, s: dict[str, float | int]) -> None:
        raw = round(float(s["time"]) * 1e6)
        base = self.now_us - self.now_us % TIME_MODULO if self.now_us is not None else 0
        kind = self.tables.event_kind.get(int(s["kind"]))
        if kind is None:
            self.problems.append(
                LogProblem(
                    self.log.where(row),
                    int(self.log.line[row]),
                    ProblemKind.MALFORMED,
                    f"EVENT of unknown kind {s['kind']}: not used",
                )
            )
            return
        side = self.tables.side.get(int(s["side"]))
        self.events.append(Event(base + raw, kind, int(s["obstacle"]), side))

    def on_status_counters(self, row: int, s: dict[str, float | int]) -> None:
        self.latest["STATUS_COUNTERS"] = s

    def on_wheel_cmd(self, row: int, s: dict[str, float | int]) -> None:
        step = int(s["step"])
        t_us = self.step_time.get(step)
        if t_us is None:  # no STEP frames: real-time mode, the log's clock
            stamp = float(self.log.time[row])
            if self.first_wheel_time is None:
                self.first_wheel_time = stamp
            since = stamp - self.first_wheel_time
            if not abs(since) <= 2 * MAX_TIME_S:  # a log read by other means: no overflow
                self.problems.append(
                    LogProblem(
                        self.log.where(row),
                        int(self.log.line[row]),
                        ProblemKind.TIME,
                        f"WHEEL_CMD: time stamp {stamp!r} s, {since:g} s after the first "
                        "WHEEL_CMD: not a time; the step is not used",
                    )
                )
                return
            t_us = round(since * 1e6)
        nan = math.nan
        odom_xy = self.latest.get("ODOM_XY", {})
        odom_theta = self.latest.get("ODOM_THETA", {})
        ref_xy = self.latest.get("REF_XY", {})
        ref_motion = self.latest.get("REF_MOTION", {})
        self.rows.append(
            {
                "t_us": t_us,
                "stamp": float(self.log.time[row]),
                "step": step,
                "x": float(odom_xy.get("x", nan)),
                "y": float(odom_xy.get("y", nan)),
                "theta": float(odom_theta.get("theta", nan)),
                "x_r": float(ref_xy.get("x", nan)),
                "y_r": float(ref_xy.get("y", nan)),
                "theta_r": float(ref_motion.get("theta", nan)),
                "v_r": float(ref_motion.get("v", nan)),
                "w_r": float(ref_motion.get("w", nan)),
                "wheel_left": float(s["left"]),
                "wheel_right": float(s["right"]),
                "status": dict(self.latest.get("STATUS", {})),
                "trk": dict(self.latest.get("STATUS_TRK", {})),
            }
        )


def _params(values: dict[str, float]) -> tuple[Params, tuple[str, ...]]:
    """Table 1 with the parameters of the log; the names of those used."""
    used = tuple(name for name in values if name in PARAM_NAMES)
    return with_param_values(Params(), values), used


def _unwrap(a: np.ndarray) -> np.ndarray:
    """Unwrapped headings, NaN kept."""
    out = a.copy()
    ok = np.isfinite(a)
    if ok.any():
        out[ok] = np.unwrap(a[ok])
    return out


def decode_log(
    log: FrameLog,
    db: Database,
    progress: Progress | None = None,
    *,
    max_problems: int = DEFAULT_MAX_PROBLEMS,
) -> DecodedLog:
    """Decode @p log (see the module's description).

    :param progress: told how many frames are done, now and then.
    :param max_problems: problems to keep (all are counted).
    :raises LogError: the log has no WHEEL_CMD frame: no control step to show.
    :raises DbcError: the DBC lacks an entry the decoder names (:mod:`mstc.can.dbc`).
    """
    dec = _Decoder(log, db, max_problems)
    dec.run(progress)
    if progress is not None:
        progress.close()
    if not dec.rows:
        raise LogError(f"{log.path}: no WHEEL_CMD frame: no control step to decode")
    params, used = _params(dec.param_values)
    obstacles = tuple(
        Obstacle(
            i,
            statistics.fmean(r[0] for r in reports),
            statistics.fmean(r[1] for r in reports),
            statistics.fmean(r[2] for r in reports),
        )
        for i, reports in sorted(dec.obstacle_reports.items())
    )
    rows = dec.rows
    n = len(rows)
    col = {name: np.array([r[name] for r in rows], dtype=float) for name in _INPUT_COLUMNS}
    left = np.array([r["wheel_left"] for r in rows], dtype=float)
    right = np.array([r["wheel_right"] for r in rows], dtype=float)
    r_w, track = params.wheel_radius, params.track_width
    v = r_w * (right + left) / 2
    w = r_w * (right - left) / track
    t = np.array([r["t_us"] for r in rows], dtype=float) / 1e6

    def status_value(row: dict[str, object], frame: str, name: str) -> float:
        values = row[frame]
        assert isinstance(values, dict)
        return float(values.get(name, math.nan))

    e1 = np.array([status_value(r, "trk", "e1") for r in rows])
    e2 = np.array([status_value(r, "trk", "e2") for r in rows])
    e3 = np.array([status_value(r, "trk", "e3") for r in rows])
    e = np.array([status_value(r, "status", "e") for r in rows])

    def status_int(row: dict[str, object], name: str, default: int) -> int:
        value = status_value(row, "status", name)
        return int(value) if math.isfinite(value) else default

    # A step without STATUS (none received yet) shows as stopped.
    stop = next(raw for raw, mode in dec.tables.mode.items() if mode is Mode.STOP)
    modes = tuple(dec.tables.mode.get(status_int(r, "mode", stop), Mode.STOP) for r in rows)
    theta, theta_r = _unwrap(col["theta"]), _unwrap(col["theta_r"])
    values = np.column_stack(
        [
            t,
            col["x"],
            col["y"],
            theta,
            col["x_r"],
            col["y_r"],
            theta_r,
            v,
            w,
            col["v_r"],
            col["w_r"],
            e1,
            e2,
            e3,
            e,
        ]
    )
    assert values.shape[1] == len(TRACE_COLUMNS)
    distance = np.array(
        [
            [math.hypot(o.x - x, o.y - y) for o in obstacles]
            for x, y in zip(col["x"], col["y"], strict=True)
        ],
        dtype=float,
    ).reshape(n, len(obstacles))
    min_distance = tuple(float(d) for d in np.nanmin(distance, axis=0)) if obstacles else ()

    faults: dict[Fault, int] = {}
    mode_counts: dict[Mode, int] = {}
    for r, mode in zip(rows, modes, strict=True):
        bits = status_int(r, "faults", 0)
        for bit in Fault:
            if bits & bit:
                faults[bit] = faults.get(bit, 0) + 1
        mode_counts[mode] = mode_counts.get(mode, 0) + 1

    status_msg = db.get_message_by_name("STATUS")
    trk_msg = db.get_message_by_name("STATUS_TRK")
    skip = {*E2E_SIGNALS, "step"}
    status_signals = [s for s in status_msg.signals if short_name(status_msg, s.name) not in skip]
    trk_signals = [s for s in trk_msg.signals if short_name(trk_msg, s.name) not in skip]
    columns = (
        "t",
        "step",
        *_INPUT_COLUMNS,
        *_WHEEL_COLUMNS,
        *(short_name(status_msg, s.name) for s in status_signals),
        *(short_name(trk_msg, s.name) for s in trk_signals),
        *(f"d{o.id}" for o in obstacles),
    )
    status_rows: list[list[object]] = []
    for i, r in enumerate(rows):
        cells: list[object] = [float(t[i]), r["step"]]
        cells += [float(col[c][i]) for c in _INPUT_COLUMNS]
        cells += [float(left[i]), float(right[i]), float(v[i]), float(w[i])]
        for frame, msg, signals in (
            ("status", status_msg, status_signals),
            ("trk", trk_msg, trk_signals),
        ):
            values_of = r[frame]
            assert isinstance(values_of, dict)
            for s in signals:
                value = values_of.get(short_name(msg, s.name))
                if value is not None and s.choices and int(value) in s.choices:
                    value = str(s.choices[int(value)])
                cells.append("" if value is None else value)
        cells += [float(d) for d in distance[i]]
        status_rows.append(cells)

    periods = np.diff(t)
    dt = float(np.median(periods)) if len(periods) else 0.0
    counters = {k: int(v) for k, v in dec.latest.get("STATUS_COUNTERS", {}).items()}
    return DecodedLog(
        log=log,
        params=params,
        params_from_log=used,
        obstacles=obstacles,
        trace=Trace(values, modes, distance),
        steps=np.array([r["step"] for r in rows], dtype=np.int64),
        status_columns=columns,
        status_rows=status_rows,
        events=tuple(dec.events),
        min_distance=min_distance,
        faults=faults,
        modes=mode_counts,
        counters=counters,
        problems=dec.problems,
        dt=round(dt, 6),
        stamps=np.array([r["stamp"] for r in rows], dtype=float),
    )
