# SPDX-License-Identifier: MIT
"""What a run leaves on disk: events.json, trace.csv, timing.json (real time)
and the figures."""

import csv
import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from mstc.controller import Event
from mstc.logs.candump import write_candump
from mstc.sim.run import TRACE_COLUMNS, RunResult

if TYPE_CHECKING:
    from mstc.can.lockstep import CanController


@dataclass(frozen=True)
class BusLog:
    """The frames of a run through CAN, and what was dropped."""

    channel: str
    controller: "CanController"

    def describe(self) -> str:
        """One line for the report."""
        traffic = self.controller.traffic
        sent = sum(1 for _, own in traffic.frames if own)
        plant = {r.value: n for r, n in self.controller.proto.drops.items() if n}
        fw = {k: v for k, v in traffic.firmware_drops.items() if v}
        return (
            f"{self.channel}: {sent} frames sent, {len(traffic.frames) - sent} received "
            f"(bus.log); dropped by the firmware: {fw or 'none'}, by the plant: {plant or 'none'}"
        )


# trace.csv puts mode after the velocities, before the errors.
_MODE_COLUMN = TRACE_COLUMNS.index("w_r") + 1


def event_record(event: Event) -> dict[str, object]:
    """An event as it appears in events.json: t [s], event, obstacle, and side
    on activate only."""
    record: dict[str, object] = {
        "t": round(event.t, 6),
        "event": str(event.kind),
        "obstacle": event.obstacle,
    }
    if event.side is not None:
        record["side"] = str(event.side)
    return record


def write_events(result: RunResult, path: Path) -> None:
    """Write ``{"events": [...], "min_distance": [...]}``, one event a line.

    min_distance is in m, rounded to 4 decimals, one entry per obstacle in
    file order.
    """
    lines = [json.dumps(event_record(e)) for e in result.events]
    events = "[\n" + ",\n".join(f"  {line}" for line in lines) + "\n]" if lines else "[]"
    min_distance = json.dumps([round(d, 4) for d in result.min_distance])
    path.write_text(f'{{"events": {events}, "min_distance": {min_distance}}}\n')


def write_trace(result: RunResult, path: Path) -> None:
    """Write trace.csv: the numeric columns, mode, and d1..dN [m]."""
    trace = result.trace
    n = trace.distance.shape[1]
    m = _MODE_COLUMN
    header = [*TRACE_COLUMNS[:m], "mode", *TRACE_COLUMNS[m:], *(f"d{i + 1}" for i in range(n))]
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        for values, mode, dist in zip(trace.values, trace.mode, trace.distance, strict=True):
            row = [repr(float(x)) for x in values]
            writer.writerow([*row[:m], str(mode), *row[m:], *(repr(float(d)) for d in dist)])


def write_outputs(
    result: RunResult, out_dir: Path, bus_log: BusLog | None = None, *, figures: bool = True
) -> Path:
    """Write every output of a run into ``out_dir/<scenario name>/``, with
    bus.log when the run went through CAN and timing.json when it ran in real
    time (a lock-step run removes a timing.json left by an earlier one).

    :returns: That folder.
    """
    folder = out_dir / result.scenario.name
    folder.mkdir(parents=True, exist_ok=True)
    write_events(result, folder / "events.json")
    write_trace(result, folder / "trace.csv")
    timing = folder / "timing.json"
    if result.timing is not None:
        timing.write_text(json.dumps(result.timing.to_json(), indent=1) + "\n")
    else:
        timing.unlink(missing_ok=True)
    if bus_log is not None:
        frames = [m for m, _ in bus_log.controller.traffic.frames]
        write_candump(folder / "bus.log", frames, bus_log.channel)
    if figures:
        from mstc.report.plots import plot_all  # matplotlib: slow to import, so only when drawing

        plot_all(result, folder)
    return folder
