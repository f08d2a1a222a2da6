# SPDX-License-Identifier: MIT
"""What a run leaves on disk: events.json, trace.csv, timing.json (real time)
and the figures.

Each run writes one folder, ``OUT/<name>/``. The folder never leaves OUT (a
name such as ``..``, from a file called ``...toml``, is refused), and a rerun
into it replaces the earlier run: the files an earlier run wrote are removed
first, so that none is left beside the new results. A folder that holds any
other file, or that is a symbolic link, is refused, never cleared.
"""

import csv
import json
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path

from mstc.errors import OutputError, writing
from mstc.logs.candump import write_candump
from mstc.logs.decode import RUN_FILE, run_json
from mstc.loop.lockstep import CanController
from mstc.loop.result import TRACE_COLUMNS, RunResult, Trace
from mstc.model import Event

FIGURES = ("path", "position_error", "angle_error", "v", "w", "distance", "overview")
"""Stems of the PNG figures :func:`mstc.report.plots.plot_all` writes."""
EXTRA_FILES = ("loop_stats.json", "wheel_trace.csv")
"""Files a bus log may add to a run's folder (:attr:`BusLog.files`): a board
image's own account under QEMU (``mstc hil --qemu``)."""
RUN_FILES = (
    "events.json",
    "trace.csv",
    "bus.log",
    "timing.json",
    RUN_FILE,
    *EXTRA_FILES,
    *(f"{stem}.png" for stem in (*FIGURES, "timing")),
)
"""Every file a run of ``mstc sim`` or ``mstc hil`` writes into its folder."""


def folder_problem(out: Path, name: str, owned: Collection[str]) -> str | None:
    """Why ``out/name`` cannot be written (see :func:`output_folder`), or None."""
    if name in ("", ".", "..") or Path(name).name != name:
        return f"{name!r} cannot name a folder inside --out {out}: rename the file"
    folder = out / name
    if folder.is_symlink():
        return f"{folder} is a symbolic link: mstc writes into real folders only"
    if folder.exists() and not folder.is_dir():
        return f"{folder} exists and is not a folder"
    if folder.is_dir():
        others = sorted(
            p.name
            for p in folder.iterdir()
            if p.name not in owned or p.is_symlink() or not p.is_file()
        )
        if others:
            shown = ", ".join(others[:5]) + (", ..." if len(others) > 5 else "")
            return (
                f"{folder} holds files mstc did not write ({shown}): not cleared; "
                "move them or choose another --out"
            )
    return None


def output_folder(out: Path, name: str, owned: Collection[str], source: str = "") -> Path:
    """``out/name``, once sure that writing there stays inside @p out and
    destroys nothing but what an earlier run wrote.

    :param out: the output folder the user named (--out).
    :param name: the folder's name: a scenario's file stem, a log's name.
    :param owned: the files such a run writes (and a rerun may remove).
    :param source: what the outputs are of (a scenario or log file), named
        first in the error.
    :raises OutputError: @p name is not a plain folder name (``""``, ``.``,
        ``..``, a path); the folder is a symbolic link or not a folder; it
        holds anything but files of @p owned.
    """
    problem = folder_problem(out, name, owned)
    if problem is not None:
        raise OutputError(f"{source}: {problem}" if source else problem)
    return out / name


def fresh_folder(out: Path, name: str, owned: Collection[str]) -> Path:
    """:func:`output_folder`, created, with every file of @p owned that an
    earlier run left there removed.

    :raises OutputError: see :func:`output_folder`.
    :raises OSError: the folder cannot be created or cleared.
    """
    folder = output_folder(out, name, owned)
    for file in owned:
        (folder / file).unlink(missing_ok=True)
    folder.mkdir(parents=True, exist_ok=True)
    return folder


@dataclass(frozen=True)
class BusLog:
    """The frames of a run through CAN, and what was dropped."""

    channel: str
    controller: CanController

    @property
    def files(self) -> dict[str, str]:
        """More files for the run's folder, by name (one of :data:`EXTRA_FILES`)."""
        return {}

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


def events_text(
    events: Sequence[Event], min_distance: Sequence[float], obstacles: Sequence[int] | None = None
) -> str:
    """The text of events.json: ``{"events": [...], "min_distance": [...]}``,
    one event a line; with @p obstacles, ``"obstacles": [...]`` too, the ids
    the min_distance entries belong to (a bus log's, whose ids need not be
    1, 2, ...).

    min_distance is in m, rounded to 4 decimals, one entry per obstacle in
    file order.
    """
    lines = [json.dumps(event_record(e)) for e in events]
    text = "[\n" + ",\n".join(f"  {line}" for line in lines) + "\n]" if lines else "[]"
    distance = json.dumps([round(d, 4) for d in min_distance])
    ids = f', "obstacles": {json.dumps(list(obstacles))}' if obstacles is not None else ""
    return f'{{"events": {text}, "min_distance": {distance}{ids}}}\n'


def events_json(result: RunResult) -> str:
    """The text of a run's events.json (:func:`events_text`)."""
    return events_text(result.events, result.min_distance)


def write_trace_csv(trace: Trace, obstacles: Sequence[int], path: Path) -> None:
    """Write trace.csv: the numeric columns, mode, and the distance to each
    obstacle, d<id> [m] (d1..dN for a scenario's)."""
    m = _MODE_COLUMN
    header = [*TRACE_COLUMNS[:m], "mode", *TRACE_COLUMNS[m:], *(f"d{i}" for i in obstacles)]
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        for values, mode, dist in zip(trace.values, trace.mode, trace.distance, strict=True):
            row = [repr(float(x)) for x in values]
            writer.writerow([*row[:m], str(mode), *row[m:], *(repr(float(d)) for d in dist)])


def write_outputs(
    result: RunResult,
    out_dir: Path,
    bus_log: BusLog | None = None,
    *,
    figures: bool = True,
    started_ns: int | None = None,
) -> Path:
    """Write every output of a run into ``out_dir/<scenario name>/``, with
    bus.log when the run went through CAN, timing.json when it ran in real
    time and run.json when @p started_ns says when it started [ns since 1970]
    (a simulation's bus.log counts from 0: an export places it there), after
    removing what an earlier run left there (:func:`fresh_folder`).

    :returns: That folder.
    :raises WriteError: the folder cannot be used (:func:`output_folder`) or
        written.
    """
    scenario = result.scenario
    with writing(f"the outputs of {scenario.path}"):
        folder = fresh_folder(out_dir, scenario.name, RUN_FILES)
        (folder / "events.json").write_text(events_json(result))
        if started_ns is not None:
            (folder / RUN_FILE).write_text(run_json(started_ns))
        ids = [o.id for o in scenario.obstacles]
        write_trace_csv(result.trace, ids, folder / "trace.csv")
        if result.timing is not None:
            timing = json.dumps(result.timing.to_json(), indent=1) + "\n"
            (folder / "timing.json").write_text(timing)
        if bus_log is not None:
            frames = [m for m, _ in bus_log.controller.traffic.frames]
            write_candump(folder / "bus.log", frames, bus_log.channel)
            for name, text in bus_log.files.items():
                (folder / name).write_text(text)
        if figures:
            # matplotlib: slow to import, so only when drawing
            from mstc.report.plots import plot_all

            plot_all(result, folder)
    return folder
