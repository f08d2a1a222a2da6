# SPDX-License-Identifier: MIT
"""Decoding bus logs (mstc.logs.decode, ``mstc plot``): events, status,
traces and figures from the frames alone.

Expected values come from hand-made frames and from the paper's times in the
scenario files.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cantools
import pytest

from conftest import SCENARIOS
from logfiles import DATA, DBC, FIGURES, NAMES, log_lines, split, write
from mstc.can.protocol import Protocol, wire_limits
from mstc.cli import main
from mstc.logs.decode import decode_log
from mstc.logs.read import read_log
from mstc.model import EventKind, Side
from mstc.plant.scenario import load_scenario
from mstc.report.plots import PlotData, plot_all

# ------------------------------------------------------- decode and plot


def hand_made_log(tmp_path: Path) -> Path:
    """Three control steps 50 ms apart, as plant and firmware would send them."""
    db = cantools.database.load_file(DBC)
    proto = Protocol()

    def frame(name: str, t: float, **values: float) -> str:
        message = db.get_message_by_name(name)
        signals = {s.name.removeprefix(f"{name}_"): 0 for s in message.signals}
        signals.pop("CRC"), signals.pop("Counter")
        signals.update(values)
        msg = proto.encode(name, signals, raw=False)
        return f"({t:.6f}) can0 {msg.arbitration_id:03X}#{bytes(msg.data).hex().upper()}"

    lines = [
        frame("PARAM_SET", 0.0, index=10, value=0.1),
        frame("PARAM_VALUE", 0.0, index=10, result=0, value=0.1),
        frame("PARAM_VALUE", 0.0, index=11, result=0, value=0.5),
        frame("PARAM_VALUE", 0.0, index=4, result=0, value=0.3),
        frame("PARAM_VALUE", 0.0, index=3, result=1, value=9.0),  # not ok: ignored
    ]
    for k in range(3):
        t = 0.05 * k
        lines += [
            frame("ODOM_XY", t, x=0.125 * k, y=1.0),
            frame("ODOM_THETA", t, theta=0.25),
            frame("REF_XY", t, x=0.5, y=1.5),
            frame("REF_MOTION", t, theta=0.5, v=0.5, w=0.25),
            frame("OBSTACLE", t, id=2, x=3.0, y=1.0, radius=0.15),
            frame("STEP", t, step=k, time=t),
        ]
        if k == 1:
            lines.append(frame("EVENT", t, kind=1, obstacle=2, side=0, time=t))
        if k == 2:
            lines.append(frame("EVENT", t, kind=2, obstacle=2, side=2, time=t))
        lines += [
            frame("STATUS", t, mode=1 if k == 2 else 0, side=2 if k == 2 else 0, e=0.5),
            frame("STATUS_TRK", t, e1=0.25, e2=-0.125, e3=0.0625),
            frame("WHEEL_CMD", t, step=k, left=10.0, right=12.0),
        ]
    path = tmp_path / "hand.log"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_decoding_a_hand_made_log(tmp_path: Path, db: object) -> None:
    log = read_log(hand_made_log(tmp_path), db)  # type: ignore[arg-type]
    assert log.problems == []
    d = decode_log(log, db)  # type: ignore[arg-type]
    trace = d.trace
    assert list(trace["t"]) == [0.0, 0.05, 0.1]
    assert list(trace["x"]) == [0.0, 0.125, 0.25]
    assert list(trace["y"]) == [1.0, 1.0, 1.0]
    assert list(trace["theta"]) == [0.25] * 3
    assert list(trace["v_r"]) == [0.5] * 3 and list(trace["w_r"]) == [0.25] * 3
    # r = 0.1 m and L = 0.5 m from PARAM_VALUE: v = r (12 + 10)/2, ω = r (12 − 10)/L.
    assert trace["v"] == pytest.approx([1.1] * 3)
    assert trace["w"] == pytest.approx([0.4] * 3)
    assert list(trace["e1"]) == [0.25] * 3 and list(trace["e"]) == [0.5] * 3
    assert [str(m) for m in trace.mode] == ["track", "track", "avoid"]
    assert [o.id for o in d.obstacles] == [2]
    assert (d.obstacles[0].x, d.obstacles[0].y, d.obstacles[0].radius) == (3.0, 1.0, 0.15)
    assert trace.distance[:, 0] == pytest.approx([3.0, 2.875, 2.75])
    assert d.min_distance == pytest.approx((2.75,))
    assert [(e.t_us, e.kind, e.obstacle, e.side) for e in d.events] == [
        (50_000, EventKind.DETECT, 2, None),
        (100_000, EventKind.ACTIVATE, 2, Side.RIGHT),
    ]
    assert (d.params.wheel_radius, d.params.track_width, d.params.d_s) == (0.1, 0.5, 0.3)
    assert d.params.d_act == 0.5  # the rejected PARAM_VALUE left Table 1's
    assert d.dt == 0.05
    assert list(d.steps) == [0, 1, 2]
    mode = d.status_columns.index("mode")
    assert [row[mode] for row in d.status_rows] == ["track", "track", "avoid"]


def test_logplot_writes_tables_and_figures(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = hand_made_log(tmp_path)
    rc = main(["plot", "--out", str(tmp_path / "out"), str(path)])
    out, err = capsys.readouterr()
    assert rc == 0, err
    folder = tmp_path / "out" / "hand"
    for stem in FIGURES:
        assert (folder / f"{stem}.png").stat().st_size > 5_000
    events = (folder / "events.json").read_text()
    assert '{"t": 0.05, "event": "detect", "obstacle": 2}' in events
    assert '"min_distance": [2.75], "obstacles": [2]' in events
    status = (folder / "status.csv").read_text().splitlines()
    assert len(status) == 4 and status[0].startswith("t,step,x,y,theta")
    trace = (folder / "trace.csv").read_text().splitlines()
    assert trace[0] == "t,x,y,theta,x_r,y_r,theta_r,v,w,v_r,w_r,mode,e1,e2,e3,e,d2"
    assert "activate  O2        right" in out


@pytest.mark.parametrize("name", NAMES)
def test_paper_logs_decode_to_the_papers_events(name: str, db: object) -> None:
    scenario = load_scenario(SCENARIOS / f"{name}.toml", wire_limits())
    log = read_log(DATA / f"{name}.log", db)  # type: ignore[arg-type]
    d = decode_log(log, db)  # type: ignore[arg-type]
    got = sorted((e.t_us, e.kind, e.obstacle, e.side) for e in d.events)
    want = sorted((e.t_us, e.event, e.obstacle, e.side) for e in scenario.expected)
    assert got == want
    # The rows' poses are the last ODOM_XY before each WHEEL_CMD (cantools, directly).
    message = cantools.database.load_file(DBC).get_message_by_frame_id(0x100)
    xs, latest = [], None
    for line in log_lines(name):
        _, ident, data = split(line)
        if ident == 0x100:
            latest = message.decode(bytes.fromhex(data))["ODOM_XY_x"]
        elif ident == 0x180:
            xs.append(latest)
    assert list(d.trace["x"]) == xs
    assert len(d.steps) == round(scenario.sim.duration / scenario.sim.dt) + 1
    assert d.dt == scenario.sim.dt
    # The paper's claim: never closer than D_s to an obstacle's centre.
    assert all(m >= scenario.params.d_s for m in d.min_distance)


def test_paper_log_figures(tmp_path: Path, db: object) -> None:
    log = read_log(DATA / "paper-circle.log", db)  # type: ignore[arg-type]
    written = plot_all(PlotData.from_log(decode_log(log, db)), tmp_path)  # type: ignore[arg-type]
    assert [p.stem for p in written] == list(FIGURES)
    assert all(p.stat().st_size > 20_000 for p in written)


def test_logplot_compares_with_a_scenarios_expected_events(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rc = main(
        [
            "plot",
            "--no-figures",
            "--out",
            str(tmp_path),
            "--scenario",
            str(SCENARIOS / "paper-line.toml"),
            str(DATA / "paper-line.log"),
        ]
    )
    out, _ = capsys.readouterr()
    assert rc == 0
    assert "activate  O1        right       6.82            6.82          0" in out
    assert "not reproduced" not in out and "not expected" not in out


def test_logplot_without_control_steps_is_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write(tmp_path, [line for line in log_lines("paper-line") if split(line)[1] != 0x180])
    assert main(["plot", "--out", str(tmp_path), str(path)]) == 2
    assert "no WHEEL_CMD frame" in capsys.readouterr().err


# ---------------------------------------- issue 13: bounded, never escaping


def test_an_absurd_time_stamp_does_not_overflow_the_decoder(tmp_path: Path, db: object) -> None:
    # Without STEP frames the rows take the log's time stamps; a log read by
    # other means may hold any double.
    lines = [
        line for line in hand_made_log(tmp_path).read_text().splitlines() if " 104#" not in line
    ]
    log = read_log(write(tmp_path, lines, "nostep.log"), db)  # type: ignore[arg-type]
    wheel = [row for row in range(len(log)) if log.frame_id[row] == 0x180]
    log.time[wheel[-1]] = 1e308
    d = decode_log(log, db)  # type: ignore[arg-type]
    assert list(d.trace["t"]) == [0.0, 0.05]
    assert [p.line for p in d.problems] == [int(log.line[wheel[-1]])]
    assert "time stamp" in d.problems[0].message


def test_decoder_problems_are_all_counted_and_the_first_ones_kept(
    tmp_path: Path, db: object
) -> None:
    lines = log_lines("paper-line")[:3000]
    bad = [i for i, line in enumerate(lines) if split(line)[1] == 0x102]  # REF_XY
    for i in bad:
        head, data = lines[i].rsplit("#", 1)
        lines[i] = f"{head}#{int(data[:2], 16) ^ 0xFF:02X}{data[2:]}"  # a wrong CRC
    log = read_log(write(tmp_path, lines), db)  # type: ignore[arg-type]
    d = decode_log(log, db, max_problems=5)  # type: ignore[arg-type]
    assert [p.line for p in d.problems] == [i + 1 for i in bad[:5]]
    assert d.problems.total == len(bad) > 100


@pytest.mark.parametrize("name", ["...log", "..log"])
def test_logplot_never_writes_outside_out(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    path = logs / name
    path.write_bytes(hand_made_log(tmp_path).read_bytes())
    out = tmp_path / "work" / "out"
    rc = main(["plot", "--no-figures", "--out", str(out), str(path)])
    assert rc == 2
    assert "--out" in capsys.readouterr().err
    assert not (tmp_path / "work").exists() or not any((tmp_path / "work").rglob("*.csv"))
    assert not (logs / "events.json").exists() and not (tmp_path / "events.json").exists()


def test_logplot_rerun_clears_the_earlier_outputs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = hand_made_log(tmp_path)
    out = tmp_path / "out"
    assert main(["plot", "--out", str(out), str(path)]) == 0
    assert (out / "hand" / "overview.png").exists()
    assert main(["plot", "--no-figures", "--out", str(out), str(path)]) == 0
    names = sorted(p.name for p in (out / "hand").iterdir())
    assert names == ["events.json", "status.csv", "trace.csv"]
    capsys.readouterr()


# ---------------------------------------------------------------- tools


@pytest.mark.parametrize("command", ["replay", "play", "plot"])
def test_log_command_help(command: str) -> None:
    exe = Path(sys.executable).parent / "mstc"
    done = subprocess.run(
        [str(exe), command, "--help"], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"usage: mstc {command}")
    assert "exit status" in done.stdout
