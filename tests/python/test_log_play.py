# SPDX-License-Identifier: MIT
"""Playing a log onto a bus (mstc.logs.play, ``mstc play``): the time line,
the rate, the selection of frames, and errors opening a bus.

Expected values come from the logs' own time stamps and a fake clock.
"""

from __future__ import annotations

import threading
from pathlib import Path

import can
import pytest

from logfiles import DATA, Run, log_lines, split
from mstc.logs.play import IdFilter, Player, select
from mstc.logs.read import read_log
from mstc.logs.replay import firmware_ids

# -------------------------------------------------------- onto a bus


class FakeClock:
    """Time that passes only when the player sleeps."""

    def __init__(self) -> None:
        self.now = 100.0
        self.sleeps: list[float] = []

    def clock(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += seconds


def test_player_follows_the_log_time_line_scaled_by_the_rate() -> None:
    stamps = [10.0, 10.5, 10.5, 12.0, 11.0, 13.0]  # the fifth goes backwards
    frames = [
        can.Message(
            timestamp=t, arbitration_id=0x100 + i, data=bytes([i] * 8), is_extended_id=False
        )
        for i, t in enumerate(stamps)
    ]
    clock = FakeClock()
    channel = "mstc-test-player"
    with (
        can.Bus(interface="virtual", channel=channel) as tx,
        can.Bus(interface="virtual", channel=channel) as rx,
    ):
        sent_at: list[float] = []
        send = tx.send

        def timed_send(msg: can.Message, timeout: float | None = None) -> None:
            sent_at.append(clock.now)
            send(msg, timeout)

        tx.send = timed_send  # type: ignore[method-assign]
        stats = Player(tx, rate=2.0, loops=2, clock=clock.clock, sleep=clock.sleep).play(frames)
        received = [rx.recv(0) for _ in range(12)]
    # Loop 1 starts at 100: due at 100 + (t − 10) / 2; the backward frame at once.
    first = [100.0, 100.25, 100.25, 101.0, 101.0, 101.5]
    second = [101.5, 101.75, 101.75, 102.5, 102.5, 103.0]
    assert sent_at == pytest.approx(first + second)
    assert stats.sent == 12 and stats.loops == 2
    assert all(s > 0 for s in clock.sleeps)
    assert [m.arbitration_id for m in received if m] == [0x100 + i for i in range(6)] * 2
    assert received[3] is not None and bytes(received[3].data) == bytes([3] * 8)


def test_player_at_infinite_rate_never_sleeps() -> None:
    frames = [
        can.Message(timestamp=t, arbitration_id=0x104, data=bytes(8), is_extended_id=False)
        for t in (0.0, 1.0, 2.0)
    ]
    clock = FakeClock()
    with can.Bus(interface="virtual", channel="mstc-test-inf") as bus:
        stats = Player(bus, rate=float("inf"), clock=clock.clock, sleep=clock.sleep).play(frames)
    assert stats.sent == 3 and clock.sleeps == []


def test_player_rejects_bad_rate_and_loops() -> None:
    with can.Bus(interface="virtual", channel="mstc-test-bad") as bus:
        with pytest.raises(ValueError, match="rate"):
            Player(bus, rate=0.0)
        with pytest.raises(ValueError, match="loops"):
            Player(bus, loops=-1)


def test_selection_sends_inputs_by_default_all_on_request_and_filters(
    db: object, fw_ids: tuple[set[int], set[int]]
) -> None:
    receives, _ = fw_ids
    lines = log_lines("paper-line")
    ids = [split(line)[1] for line in lines]
    log = read_log(DATA / "paper-line.log", db)  # type: ignore[arg-type]
    inputs, _ = firmware_ids(db)  # type: ignore[arg-type]
    chosen = select(log, inputs=inputs)
    assert [m.arbitration_id for m in chosen] == [i for i in ids if i in receives]
    assert len(select(log, inputs=None)) == len(lines)
    steps = select(log, inputs=inputs, id_filter=IdFilter.parse("0x100,0x103-0x104"))
    assert [m.arbitration_id for m in steps] == [i for i in ids if i in (0x100, 0x103, 0x104)]
    first = lines[0].split()
    assert chosen[0].timestamp == float(first[0][1:-1]) and chosen[0].channel == first[1]


def test_id_filter_reads_hex_ranges_and_names(db: object) -> None:
    f = IdFilter.parse("0x100, 104-0x110 ,STEP", db)  # type: ignore[arg-type]
    assert [i in f for i in (0x100, 0x101, 0x104, 0x10A, 0x110, 0x111)] == [
        True,
        False,
        True,
        True,
        True,
        False,
    ]
    for bad, message in [
        ("0x110-0x104", "reversed"),
        ("zz", "bad item 'zz'"),
        ("0x100,,0x101", "empty item"),
        ("1-2-3", "bad range"),
        ("0x40000000", "bad item"),
    ]:
        with pytest.raises(ValueError, match=message):
            IdFilter.parse(bad, db)  # type: ignore[arg-type]


def test_cli_plays_onto_a_virtual_bus(run_play: Run) -> None:
    lines = log_lines("paper-line")
    steps = sum(1 for line in lines if split(line)[1] == 0x104)
    channel = "mstc-test-cli"
    with can.Bus(interface="virtual", channel=channel) as rx:
        rc, out, _ = run_play(
            "--interface", "virtual", "--channel", channel, "--rate", "inf", "--id-filter", "STEP",
            DATA / "paper-line.log",
        )  # fmt: skip
        received = []
        while (msg := rx.recv(0)) is not None:
            received.append(msg)
    assert rc == 0, out
    assert f"sent {steps:,} frames in 1 loop(s)" in out
    assert len(received) == steps and {m.arbitration_id for m in received} == {0x104}


def test_cli_says_why_a_bus_cannot_be_opened(run_play: Run) -> None:
    rc, out, err = run_play(
        "--interface", "socketcan", "--channel", "mstc-none0", DATA / "paper-line.log"
    )
    assert rc == 3
    assert "cannot open socketcan bus 'mstc-none0'" in err
    rc, _, err = run_play("--interface", "no-such-interface", DATA / "paper-line.log")
    assert rc == 3 and "no-such-interface" in err


def test_bus_options_belong_to_play(run_replay: Run, run_play: Run) -> None:
    with pytest.raises(SystemExit) as exc:
        run_replay("--rate", "2", DATA / "paper-line.log")
    assert exc.value.code == 2
    with pytest.raises(SystemExit) as exc:
        run_play("--interface", "virtual", "--rate", "0", DATA / "paper-line.log")
    assert exc.value.code == 2


# ------------------------------------------------- issue 13: absurd time stamps


def test_play_skips_an_absurd_time_stamp_instead_of_crashing(tmp_path: Path, run_play: Run) -> None:
    odom = [line for line in log_lines("paper-line") if split(line)[1] == 0x100][:3]
    frames = [line.split()[2] for line in odom]
    path = tmp_path / "bus.log"
    path.write_text(
        f"(0.000000) vcan0 {frames[0]}\n(0.001000) vcan0 {frames[1]}\n(1e300) vcan0 {frames[2]}\n"
    )
    channel = "mstc-test-absurd"
    with can.Bus(interface="virtual", channel=channel) as rx:
        rc, out, err = run_play("--interface", "virtual", "--channel", channel, path)
        received = [rx.recv(0) for _ in range(3)]
    assert rc == 0, err
    assert f"{path}:3: time stamp" in err
    assert "sent 2 frames" in out
    assert [m.arbitration_id for m in received if m] == [0x100, 0x100]


def test_player_sleeps_in_pieces_a_blocking_call_can_take() -> None:
    # A frame due in 1e300 s (a log read by other means, or --rate 1e-300):
    # the player waits in pieces, each one a sleep the system accepts, until
    # interrupted; it never asks for one sleep it cannot take.
    frames = [
        can.Message(timestamp=t, arbitration_id=0x100, data=bytes(8), is_extended_id=False)
        for t in (0.0, 1e300)
    ]
    clock = FakeClock()

    def sleep(seconds: float) -> None:
        assert 0 < seconds <= threading.TIMEOUT_MAX
        clock.sleep(seconds)
        if len(clock.sleeps) == 3:
            raise KeyboardInterrupt

    with can.Bus(interface="virtual", channel="mstc-test-huge") as bus:
        with pytest.raises(KeyboardInterrupt):
            Player(bus, clock=clock.clock, sleep=sleep).play(frames)
    assert len(clock.sleeps) == 3


def test_player_wakes_on_time_after_sleeping_in_pieces() -> None:
    frames = [
        can.Message(timestamp=t, arbitration_id=0x100, data=bytes(8), is_extended_id=False)
        for t in (0.0, 5000.0)
    ]
    clock = FakeClock()
    with can.Bus(interface="virtual", channel="mstc-test-long") as bus:
        stats = Player(bus, clock=clock.clock, sleep=clock.sleep).play(frames)
    assert stats.sent == 2
    assert sum(clock.sleeps) == pytest.approx(5000.0)
    assert clock.now == pytest.approx(5100.0)


def test_cli_takes_canplayers_options_count_verbose_and_mapping(run_play: Run) -> None:
    """-n (canplayer -n: stop after N frames), -v (echo each frame sent, in
    candump -L form) and interface mapping BUS=LOG (canplayer's vcan0=can0:
    the frames logged on LOG go onto BUS; a channel not mapped is not sent)."""
    lines = log_lines("paper-line")
    logged_on = lines[0].split()[1]  # the channel the log was recorded on
    first = [line for line in lines if split(line)[1] == 0x104][:5]
    channel = "mstc-test-map"
    with can.Bus(interface="virtual", channel=channel) as rx:
        rc, out, _ = run_play(
            "-i", "virtual", "-m", f"{channel}={logged_on}", "--rate", "inf", "--id-filter",
            "STEP", "-n", "5", "-v", DATA / "paper-line.log",
        )  # fmt: skip
        received = []
        while (msg := rx.recv(0)) is not None:
            received.append(msg)
    assert rc == 0, out
    assert len(received) == 5
    echoed = [line for line in out.splitlines() if line.startswith("(")]
    # The echo is the log's own line, the time stamp and channel aside.
    assert [e.split()[2] for e in echoed] == [f.split()[2] for f in first]
    assert all(e.split()[1] == channel for e in echoed)
    assert "sent 5 frames" in out
    rc, out, _ = run_play(
        "-i", "virtual", "-m", f"{channel}=not-in-the-log", DATA / "paper-line.log"
    )  # fmt: skip
    assert rc == 2
