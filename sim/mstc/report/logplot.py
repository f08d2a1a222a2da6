# SPDX-License-Identifier: MIT
"""What ``mstc plot`` makes of a bus log (:mod:`mstc.logs.decode`): events.json
and trace.csv in the formats of a simulation's, status.csv, the figures, and
the table ``make sim`` prints."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

from mstc.errors import writing
from mstc.logs.decode import DecodedLog
from mstc.plant.scenario import ExpectedEvent
from mstc.report.outputs import FIGURES, events_text, fresh_folder, write_trace_csv
from mstc.report.table import match_events

PLOT_FILES = ("events.json", "trace.csv", "status.csv", *(f"{stem}.png" for stem in FIGURES))
"""Every file ``mstc plot`` writes into its folder."""


def write_log_outputs(decoded: DecodedLog, out: Path, *, figures: bool = True) -> Path:
    """Write events.json, trace.csv (distance columns named by obstacle id),
    status.csv and, with @p figures, the figures into ``out/<decoded.name>/``,
    after removing what an earlier run left there.

    :returns: That folder.
    :raises WriteError: it cannot be used or written.
    """
    with writing(f"the outputs into {out / decoded.name}"):
        folder = fresh_folder(out, decoded.name, PLOT_FILES)
        ids = [o.id for o in decoded.obstacles]
        text = events_text(decoded.events, decoded.min_distance, ids)
        (folder / "events.json").write_text(text)
        write_trace_csv(decoded.trace, ids, folder / "trace.csv")
        write_status_csv(decoded, folder / "status.csv")
        if figures:
            from mstc.report.plots import PlotData, plot_all  # matplotlib: only when drawing

            plot_all(PlotData.from_log(decoded), folder)
    return folder


def write_status_csv(decoded: DecodedLog, path: Path) -> None:
    """status.csv: one row per control step (:attr:`DecodedLog.status_columns`)."""
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(decoded.status_columns)
        for row in decoded.status_rows:
            writer.writerow([repr(c) if isinstance(c, float) else c for c in row])


_NONE = "—"


def format_events(
    decoded: DecodedLog,
    expected: Sequence[ExpectedEvent] = (),
    folder: Path | None = None,
) -> str:
    """The table ``make sim`` prints, from the log: events (beside @p expected,
    with the difference in control steps), minimum distances against D_s,
    faults, modes, the firmware's drop counters."""
    log = decoded.log
    dt_us = round(decoded.dt * 1e6)
    obstacles = {o.id: o for o in decoded.obstacles}
    row = "  {:<9} {:<9} {:<6} {:>9}  {:>14}  {:>9}  {}"
    span = float(decoded.trace["t"][-1] - decoded.trace["t"][0])
    lines = [
        f"{decoded.name}: {log.path} (bus log, {len(decoded.steps)} steps, {span:g} s"
        + (f", dt {decoded.dt:g} s" if decoded.dt else "")
        + f", {len(decoded.obstacles)} obstacles)",
        row.format("event", "obstacle", "side", "t log [s]", "t expected [s]", "Δ [steps]", "note"),
    ]
    for m in match_events(decoded.events, tuple(expected)):
        side = m.simulated.side if m.simulated else (m.expected.side if m.expected else None)
        t_log = f"{m.simulated.t:.2f}" if m.simulated else _NONE
        t_exp = f"{m.expected.t:.2f}" if m.expected else _NONE
        steps = _NONE
        if m.simulated and m.expected and dt_us:
            d = (m.simulated.t_us - m.expected.t_us) / dt_us
            steps = (f"{round(d):+d}" if d else "0") if d == round(d) else f"{d:+.1f}"
        note = ""
        if m.simulated is None:
            note = "not reproduced"
        elif m.expected is None:
            note = "not expected" if expected else ""
        elif m.expected.side != m.simulated.side:
            note = f"side differs: expected {m.expected.side}"
        cells = (m.kind, f"O{m.obstacle}", side or "", t_log, t_exp, steps, note)
        lines.append(row.format(*cells).rstrip())
    if not decoded.events and not expected:
        lines.append("  (no events)")
    p = decoded.params
    for i, (o, d) in enumerate(zip(decoded.obstacles, decoded.min_distance, strict=True)):
        d_s = p.safe_distance(obstacles[o.id].radius)
        verdict = "ok" if d >= d_s else "BELOW D_s"
        label = "min distance" if i == 0 else ""
        lines.append(f"  {label:<13} O{o.id} {d:.4f} m  (D_s {d_s:g} m: {verdict})")
    for fault, count in decoded.faults.items():
        lines.append(f"  {'fault':<13} {str(fault.name).lower()} in {count} steps")
    modes = ", ".join(f"{mode} {n}" for mode, n in decoded.modes.items())
    lines.append(f"  {'steps':<13} {modes}")
    if decoded.counters:
        counts = ", ".join(f"{k} {v}" for k, v in decoded.counters.items())
        lines.append(f"  {'fw dropped':<13} {counts} (last STATUS_COUNTERS)")
    from_log = ", ".join(decoded.params_from_log) or "none: Table 1 defaults"
    lines.append(f"  {'params':<13} from the log: {from_log}")
    if folder is not None:
        lines.append(f"  {'output':<13} {folder}/")
    return "\n".join(lines)
