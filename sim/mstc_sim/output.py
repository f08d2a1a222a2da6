"""What a run leaves on disk: events.json, trace.csv and the figures."""

import csv
import json
from pathlib import Path

from mstc_sim.controller import Event
from mstc_sim.plots import plot_all
from mstc_sim.run import TRACE_COLUMNS, RunResult

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


def write_outputs(result: RunResult, out_dir: Path) -> Path:
    """Write every output of a run into ``out_dir/<scenario name>/``.

    :returns: That folder.
    """
    folder = out_dir / result.scenario.name
    folder.mkdir(parents=True, exist_ok=True)
    write_events(result, folder / "events.json")
    write_trace(result, folder / "trace.csv")
    plot_all(result, folder)
    return folder
