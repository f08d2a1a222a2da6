# SPDX-License-Identifier: MIT
"""Bus logs: replay through the firmware, canplayer-like playing, decoding and
figures (issue: CAN trace replay, decoding and plots from bus logs).

Expected values come from the logs themselves (their lines, split by hand,
and cantools decoding single frames), from hand-made frames, and from the
paper's times in the scenario files; never from the replayer's own output.
"""

from __future__ import annotations

import ctypes
import io
import random
import re
import subprocess
from collections.abc import Callable
from pathlib import Path

import can
import cantools
import numpy as np
import pytest

from conftest import ROOT, SCENARIOS
from mstc_sim.controller import EventKind, Side
from mstc_sim.logcli import logplot_main, replay_main
from mstc_sim.logdecode import decode_log
from mstc_sim.logread import LogError, ProblemKind, read_log
from mstc_sim.player import IdFilter, Player, select
from mstc_sim.plots import plot_all
from mstc_sim.progress import Progress
from mstc_sim.protocol import Protocol, e2e_crc, load_database
from mstc_sim.replay import firmware_ids, replay
from mstc_sim.scenario import load_scenario

DATA = ROOT / "tests" / "data"
NAMES = ("paper-line", "paper-circle")
DBC = ROOT / "firmware" / "comm" / "mstc.dbc"
CANDUMP_LINE = re.compile(r"^\(\d+\.\d{6}\) \S+ [0-9A-F]{3}#(?:[0-9A-F]{2}){0,8}$")
FIGURES = ("path", "position_error", "angle_error", "v", "w", "distance", "overview")


# ---------------------------------------------------------------- fixtures


@pytest.fixture(scope="session")
def float_lib(sil_lib: Path) -> Path:
    """The float build: the committed logs were recorded from it. Under
    NUMERIC=fixed, $MSTC_SIL_LIB is the fixed build, and the float one must
    have been built too; without it the tests fail, loudly."""
    dll = ctypes.CDLL(str(sil_lib.resolve()))
    dll.mstc_sil_numeric.restype = ctypes.c_char_p
    if dll.mstc_sil_numeric() == b"float":
        return sil_lib
    other = ROOT / "build" / "host" / "float" / "libmstc_sil.so"
    if not other.is_file():
        pytest.fail(
            f"{sil_lib} is not the float build, and {other} does not exist: the committed "
            "logs replay bit-exact through the float build only (make lib NUMERIC=float)",
            pytrace=False,
        )
    return other


@pytest.fixture(scope="session")
def db() -> cantools.database.can.Database:
    return load_database()


@pytest.fixture(scope="session")
def fw_ids() -> tuple[set[int], set[int]]:
    """What the DBC's FW node receives and sends, read with cantools directly."""
    raw = cantools.database.load_file(DBC)
    receives = {m.frame_id for m in raw.messages if "FW" in m.receivers}
    sends = {m.frame_id for m in raw.messages if "FW" in m.senders}
    return receives, sends


def split(line: str) -> tuple[float, int, str]:
    """(time, identifier, hex data) of a candump -L line, by hand."""
    stamp, _, frame = line.split()
    ident, _, data = frame.partition("#")
    return float(stamp[1:-1]), int(ident, 16), data


def log_lines(name: str) -> list[str]:
    return (DATA / f"{name}.log").read_text().splitlines()


@pytest.fixture(scope="module")
def short_lines() -> list[str]:
    """The first ~3 s of the line scenario's log, up to a WHEEL_CMD (the end of
    a control step's answer), so that it replays bit-exact on its own."""
    lines = log_lines("paper-line")[:1600]
    last = max(i for i, line in enumerate(lines) if split(line)[1] == 0x180)
    return lines[: last + 1]


def write(tmp_path: Path, lines: list[str], name: str = "bus.log") -> Path:
    path = tmp_path / name
    path.write_text("".join(line + "\n" for line in lines))
    return path


Run = Callable[..., tuple[int, str, str]]


@pytest.fixture
def run_replay(capsys: pytest.CaptureFixture[str], float_lib: Path) -> Run:
    """tools/replay in process: (exit status, stdout, stderr)."""

    def run(*args: str | Path, lib: bool = True) -> tuple[int, str, str]:
        argv = [str(a) for a in args]
        if lib:
            argv = ["--lib", str(float_lib), *argv]
        rc = replay_main(argv)
        out, err = capsys.readouterr()
        return rc, out, err

    return run


def index_of(lines: list[str], frame_id: int, after: float = 0.0) -> int:
    """The first line of @p frame_id at or after time @p after."""
    return next(
        i for i, line in enumerate(lines) if split(line)[1] == frame_id and split(line)[0] >= after
    )


# ---------------------------------------------------- the committed logs


@pytest.mark.parametrize("name", NAMES)
def test_committed_log_replays_bit_exact(
    name: str, run_replay: Run, fw_ids: tuple[set[int], set[int]]
) -> None:
    receives, sends = fw_ids
    frames = [split(line) for line in log_lines(name)]
    rc, out, err = run_replay("--strict", "--quiet", DATA / f"{name}.log")
    assert rc == 0, out + err
    assert "bit-exact" in out
    fed = sum(1 for _, i, _ in frames if i in receives)
    recorded = sum(1 for _, i, _ in frames if i in sends)
    assert re.search(rf"fed\s+{fed:,}\s", out)
    assert re.search(rf"recorded from FW\s+{recorded:,}\s", out)
    assert re.search(rf"compared\s+{recorded:,}\s+matched {recorded:,}, differing 0", out)
    assert err == ""


@pytest.mark.parametrize("name", NAMES)
def test_committed_log_is_small_candump(name: str) -> None:
    path = DATA / f"{name}.log"
    assert path.stat().st_size < 1_500_000
    assert all(CANDUMP_LINE.match(line) for line in log_lines(name))


@pytest.mark.parametrize("ext", ["asc", "blf"])
def test_asc_and_blf_logs_replay_through_python_cans_readers(
    ext: str, tmp_path: Path, db: object, float_lib: Path
) -> None:
    path = tmp_path / f"paper-line.{ext}"
    with can.Logger(str(path)) as writer:
        for msg in can.LogReader(str(DATA / "paper-line.log")):
            writer.on_message_received(msg)
    log = read_log(path, db)  # type: ignore[arg-type]
    assert log.format == ext
    assert len(log) == len(log_lines("paper-line"))
    result = replay(log, db, float_lib)  # type: ignore[arg-type]
    assert result.identical
    assert result.matched == result.recorded > 0


def test_format_is_taken_from_the_extension_or_named(tmp_path: Path, run_replay: Run) -> None:
    path = tmp_path / "session.txt"
    path.write_bytes((DATA / "paper-line.log").read_bytes())
    rc, _, err = run_replay(path)
    assert rc == 2
    assert "--format" in err and ".txt" in err
    rc, out, _ = run_replay("--format", "candump", path)
    assert rc == 0 and "bit-exact" in out


def test_library_that_does_not_exist_is_exit_3(run_replay: Run, tmp_path: Path) -> None:
    rc, _, err = run_replay("--lib", tmp_path / "nope.so", DATA / "paper-line.log", lib=False)
    assert rc == 3
    assert "nope.so" in err and "make lib" in err


# ------------------------------------------------------------- bad logs


def test_garbage_line_is_reported_with_its_line_and_skipped(
    tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    lines = [*short_lines[:100], "hello world", *short_lines[100:]]
    path = write(tmp_path, lines)
    rc, out, err = run_replay(path)
    assert f"{path}:101: expected '(time) interface id#data', got 2 fields" in err
    assert rc == 0 and "bit-exact" in out
    rc, _, err = run_replay("--strict", path)
    assert rc == 2 and "(--strict)" in err


def test_binary_garbage_line_is_reported(
    tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    path = tmp_path / "bus.log"
    text = "".join(line + "\n" for line in short_lines[:50]).encode()
    rest = "".join(line + "\n" for line in short_lines[50:]).encode()
    path.write_bytes(text + b"\x00\xff\xfe\x81garbage\n" + rest)
    rc, out, err = run_replay(path)
    assert f"{path}:51: binary data, not text" in err
    assert rc == 0 and "bit-exact" in out


def test_truncated_input_line_is_reported_and_its_loss_shows(
    tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    i = index_of(short_lines, 0x100, after=1.0)  # an ODOM_XY
    stamp, chan, frame = short_lines[i].split()
    lines = list(short_lines)
    lines[i] = f"{stamp} {chan} {frame[:9]}"  # 100#54010: an odd number of digits
    path = write(tmp_path, lines)
    rc, out, err = run_replay(path)
    assert f"{path}:{i + 1}: odd number of hex digits in the data (5): truncated?" in err
    # The firmware stepped on the previous odometry: its answer differs.
    assert rc == 1
    first = int(re.search(rf"first difference: {re.escape(str(path))}:(\d+)", out).group(1))
    assert first > i + 1


def test_log_cut_in_its_last_line_is_reported(
    tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    # candump killed while writing the last WHEEL_CMD: no newline, odd digits.
    path = tmp_path / "bus.log"
    text = "".join(line + "\n" for line in short_lines[:-1]) + short_lines[-1][:-3]
    path.write_text(text)
    n = len(short_lines)
    rc, out, err = run_replay(path)
    assert f"{path}:{n}: odd number of hex digits" in err
    assert rc == 1
    assert re.search(r"extra\s+1\s", out)
    assert "0x180 WHEEL_CMD: sent by the firmware, but not in the log" in out


def test_unknown_and_extended_identifiers_are_reported_and_not_fed(
    tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    stamp = short_lines[200].split()[0]
    lines = [
        *short_lines[:200],
        f"{stamp} sil0 7AB#0011223344556677",
        f"{stamp} sil0 00000100#0011223344556677",
        *short_lines[200:],
    ]
    path = write(tmp_path, lines)
    rc, out, err = run_replay(path)
    assert f"{path}:201: identifier 7AB is not in the DBC: not fed" in err
    assert f"{path}:202: extended identifier 00000100 is not in the DBC: not fed" in err
    assert rc == 0 and "bit-exact" in out
    assert re.search(r"not fed\s+2\s", out)


def test_time_going_backwards_is_reported_and_the_order_kept(
    tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    i = index_of(short_lines, 0x101, after=1.0)
    lines = list(short_lines)
    _, chan, frame = lines[i].split()
    lines[i] = f"(0.000000) {chan} {frame}"
    path = write(tmp_path, lines)
    rc, out, err = run_replay(path)
    t_before = split(short_lines[i - 1])[0]
    assert f"{path}:{i + 1}: time goes backwards: 0.000000 s after {t_before:.6f} s" in err
    assert rc == 0 and "bit-exact" in out


def test_wrong_length_is_reported_and_fed_like_a_board_gets_it(
    tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    i = index_of(short_lines, 0x104, after=1.0)  # a STEP
    stamp = short_lines[i].split()[0]
    lines = [*short_lines[:i], f"{stamp} sil0 100#0011", *short_lines[i:]]
    path = write(tmp_path, lines)
    rc, out, err = run_replay(path)
    assert f"{path}:{i + 1}: 100 has 2 data bytes, the DBC says 8" in err
    # The firmware counted the short frame: its telemetry says so.
    assert rc == 1
    first = int(re.search(rf"first difference: {re.escape(str(path))}:(\d+)", out).group(1))
    assert first > i + 2


@pytest.mark.parametrize(
    ("frame", "problem"),
    [
        ("100#R", "remote frame 100#R: not fed"),
        ("100##1001122", "CAN FD frame 100##...: the firmware takes classic CAN"),
        ("20000080#0000000000000000", "error frame 20000080#0000000000000000: not fed"),
        ("10#0011", "identifier '10' must have 3 (standard) or 8 (extended) hex digits"),
        ("FFF#00", "standard identifier FFF above 7FF"),
        ("100#00112233445566778899", "10 data bytes: a classic frame has at most 8"),
        ("100#00GG", "data is not hexadecimal"),
        ("100-0011", "no '#' between identifier and data"),
    ],
)
def test_frames_the_firmware_cannot_take_are_skipped(
    frame: str, problem: str, tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    stamp = short_lines[30].split()[0]
    path = write(tmp_path, [*short_lines[:30], f"{stamp} sil0 {frame}", *short_lines[30:]])
    rc, out, err = run_replay(path)
    assert f"{path}:31: {problem}" in err
    assert rc == 0 and "bit-exact" in out


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ("0.5 sil0 100#00", "time stamp not in parentheses: '0.5'"),
        ("(0.5x) sil0 100#00", "bad time stamp '(0.5x)'"),
        ("(nan) sil0 100#00", "time stamp not finite: '(nan)'"),
        ("(0.5) sil0", "expected '(time) interface id#data', got 2 fields"),
    ],
)
def test_bad_fields_are_named(
    line: str, problem: str, tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    path = write(tmp_path, [*short_lines[:10], line, *short_lines[10:]])
    rc, _, err = run_replay(path)
    assert f"{path}:11: {problem}" in err
    assert rc == 0


def test_many_problems_are_counted_after_the_first_ones(
    tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    path = write(tmp_path, [*short_lines[:10], *(["junk"] * 50), *short_lines[10:]])
    rc, _, err = run_replay(path)
    assert rc == 0
    assert err.count(": expected '(time) interface id#data'") == 20
    assert "... and 30 more problems (50 malformed in all)" in err


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"", "no usable CAN frame (the file is empty)"),
        (bytes(range(256)) * 40, "no usable CAN frame in"),
        (b"not a log\nat all\n", "no usable CAN frame in 2 lines (2 problems: malformed)"),
    ],
)
def test_logs_without_a_frame_are_fatal(
    content: bytes, message: str, tmp_path: Path, run_replay: Run
) -> None:
    path = tmp_path / "bus.log"
    path.write_bytes(content)
    rc, out, err = run_replay(path)
    assert rc == 2
    assert message in err and out == ""


def test_missing_file_and_directory_are_fatal(tmp_path: Path, run_replay: Run) -> None:
    rc, _, err = run_replay(tmp_path / "none.log")
    assert rc == 2 and "cannot read" in err
    folder = tmp_path / "dir.log"
    folder.mkdir()
    rc, _, err = run_replay(folder)
    assert rc == 2 and "is a directory" in err


def test_truncated_blf_is_reported_and_read_up_to_the_damage(tmp_path: Path, db: object) -> None:
    path = tmp_path / "bus.blf"
    with can.Logger(str(path)) as writer:
        for msg in can.LogReader(str(DATA / "paper-line.log")):
            writer.on_message_received(msg)
    raw = path.read_bytes()
    path.write_bytes(raw[: len(raw) // 2])
    log = read_log(path, db)  # type: ignore[arg-type]
    assert 0 < len(log) < len(log_lines("paper-line"))
    assert [p.kind for p in log.problems] == [ProblemKind.READ]
    assert "truncated" in str(log.problems[0])


def test_random_damage_never_crashes_the_tool(
    tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    rng = random.Random(20240505)
    base = "".join(line + "\n" for line in short_lines[:600]).encode()
    for case in range(40):
        data = bytearray(base)
        for _ in range(rng.randint(1, 12)):
            if not data:
                break
            at = rng.randrange(len(data))
            op = rng.choice(("delete", "insert", "replace", "cut"))
            if op == "delete":
                del data[at : at + rng.randint(1, 40)]
            elif op == "insert":
                data[at:at] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 8)))
            elif op == "replace":
                data[at] = rng.randrange(256)
            else:
                del data[at:]
        path = tmp_path / f"fuzz{case}.log"
        path.write_bytes(bytes(data))
        rc, out, err = run_replay("--quiet", path)
        assert rc in (0, 1, 2), (case, out, err)
        assert "Traceback" not in out + err


# ------------------------------------------------------- first difference


def test_altered_frame_is_the_first_difference_with_its_signals(
    tmp_path: Path, run_replay: Run, fw_ids: tuple[set[int], set[int]]
) -> None:
    lines = log_lines("paper-line")
    i = index_of(lines, 0x181, after=2.0)  # a STATUS
    stamp, chan, frame = lines[i].split()
    ident, data = frame.split("#")
    original = bytes.fromhex(data)
    altered = bytearray(original)
    altered[3] ^= 0x01
    lines[i] = f"{stamp} {chan} {ident}#{bytes(altered).hex().upper()}"
    path = write(tmp_path, lines)

    rc, out, _ = run_replay(path)
    assert rc == 1
    t = split(lines[i])[0]
    assert (
        f"first difference: {path}:{i + 1}, t = {t:.6f} s: 0x181 STATUS: "
        "the firmware sent other bytes" in out
    )
    assert f"recorded  {' '.join(f'{b:02X}' for b in altered)}" in out
    assert f"sent      {' '.join(f'{b:02X}' for b in original)}" in out
    # The marked signals are those the altered byte carries (cantools, directly).
    message = cantools.database.load_file(DBC).get_message_by_frame_id(0x181)
    before = message.decode(original, decode_choices=False)
    after = message.decode(bytes(altered), decode_choices=False)
    differing = {k.removeprefix("STATUS_") for k in before if before[k] != after[k]}
    assert differing
    table = out.split("sent      ", 1)[1].splitlines()[2:]
    marked = {row.split()[0] for row in table if row.rstrip().endswith("*")}
    assert marked == differing
    recorded = sum(1 for line in lines if split(line)[1] in fw_ids[1])
    assert re.search(rf"compared\s+{recorded:,}\s+matched {recorded - 1:,}, differing 1", out)
    assert re.search(r"missing\s+0\s", out) and re.search(r"extra\s+0\s", out)
    assert "DIFFERENT" in out


def test_frame_missing_from_the_log_is_extra(tmp_path: Path, run_replay: Run) -> None:
    lines = log_lines("paper-line")
    i = index_of(lines, 0x182, after=5.0)  # a STATUS_TRK
    path = write(tmp_path, lines[:i] + lines[i + 1 :])
    rc, out, _ = run_replay(path)
    assert rc == 1
    assert re.search(r"extra\s+1\s", out) and re.search(r"missing\s+0\s", out)
    assert "0x182 STATUS_TRK: sent by the firmware, but not in the log" in out
    assert re.search(r"differing 0\b", out)


def test_frame_recorded_twice_is_missing(tmp_path: Path, run_replay: Run) -> None:
    lines = log_lines("paper-line")
    i = index_of(lines, 0x182, after=5.0)
    path = write(tmp_path, [*lines[: i + 1], lines[i], *lines[i + 1 :]])
    rc, out, _ = run_replay(path)
    assert rc == 1
    assert re.search(r"missing\s+1\s", out) and re.search(r"extra\s+0\s", out)
    assert (
        f"first difference: {path}:{i + 2}, t = {split(lines[i])[0]:.6f} s: 0x182 STATUS_TRK: "
        "recorded, but the firmware did not send it" in out
    )


def test_altered_input_changes_the_answer_that_follows(tmp_path: Path, run_replay: Run) -> None:
    lines = log_lines("paper-line")
    i = index_of(lines, 0x100, after=4.0)  # an ODOM_XY, re-protected so that it is taken
    stamp, chan, frame = lines[i].split()
    data = bytearray(bytes.fromhex(frame[4:]))
    data[4] ^= 0x10  # x moves by 2^-4 m
    data[0] = e2e_crc(Protocol().data_id(0x100), data)
    lines[i] = f"{stamp} {chan} 100#{bytes(data).hex().upper()}"
    path = write(tmp_path, lines)
    rc, out, _ = run_replay(path)
    assert rc == 1
    first = int(re.search(rf"first difference: {re.escape(str(path))}:(\d+)", out).group(1))
    next_step = index_of(lines[i:], 0x104) + i  # the STEP of that step
    assert next_step + 1 < first <= next_step + 8
    assert "answering line" in out and "0x104 STEP" in out


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


def test_cli_plays_onto_a_virtual_bus(run_replay: Run) -> None:
    lines = log_lines("paper-line")
    steps = sum(1 for line in lines if split(line)[1] == 0x104)
    channel = "mstc-test-cli"
    with can.Bus(interface="virtual", channel=channel) as rx:
        rc, out, _ = run_replay(
            "--to-bus", "virtual", "--channel", channel, "--rate", "inf", "--id-filter", "STEP",
            DATA / "paper-line.log", lib=False,
        )  # fmt: skip
        received = []
        while (msg := rx.recv(0)) is not None:
            received.append(msg)
    assert rc == 0, out
    assert f"sent {steps:,} frames in 1 loop(s)" in out
    assert len(received) == steps and {m.arbitration_id for m in received} == {0x104}


def test_cli_says_why_a_bus_cannot_be_opened(run_replay: Run) -> None:
    rc, out, err = run_replay(
        "--to-bus", "socketcan", "--channel", "mstc-none0", DATA / "paper-line.log", lib=False
    )
    assert rc == 3
    assert "cannot open socketcan bus 'mstc-none0'" in err
    rc, _, err = run_replay("--to-bus", "no-such-interface", DATA / "paper-line.log", lib=False)
    assert rc == 3 and "no-such-interface" in err


def test_bus_options_need_to_bus(run_replay: Run) -> None:
    with pytest.raises(SystemExit) as exc:
        run_replay("--rate", "2", DATA / "paper-line.log")
    assert exc.value.code == 2
    with pytest.raises(SystemExit):
        run_replay("--to-bus", "virtual", "--rate", "0", DATA / "paper-line.log", lib=False)


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
    rc = logplot_main(["--out", str(tmp_path / "out"), str(path)])
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
    scenario = load_scenario(SCENARIOS / f"{name}.toml")
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
    written = plot_all(decode_log(log, db).plot_data(), tmp_path)  # type: ignore[arg-type]
    assert [p.stem for p in written] == list(FIGURES)
    assert all(p.stat().st_size > 20_000 for p in written)


def test_logplot_compares_with_a_scenarios_expected_events(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rc = logplot_main(
        [
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
    assert logplot_main(["--out", str(tmp_path), str(path)]) == 2
    assert "no WHEEL_CMD frame" in capsys.readouterr().err


# ------------------------------------------------------------- progress


class Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_is_plain_lines_every_tenth_when_not_a_terminal(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv("CI", raising=False)
    now = [0.0]
    stream = io.StringIO()
    p = Progress(1000, "replay", stream=stream, clock=lambda: now[0])
    for done in range(0, 1001, 10):
        now[0] = done / 100  # 10 s in all
        p.update(done)
    p.close()
    lines = stream.getvalue().splitlines()
    # Nothing within the first second (before 10 %), then one line per tenth to 90 %.
    assert [line.split(":")[1].split("%")[0].strip() for line in lines[:-1]] == [
        str(n) for n in range(10, 100, 10)
    ]
    assert lines[1] == "replay: 20% (200/1,000 frames), 0:02 elapsed, 0:08 left"
    assert lines[-1] == "replay: done in 0:10"
    assert "\r" not in stream.getvalue()


def test_progress_is_a_bar_with_eta_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("CI", raising=False)
    now = [0.0]
    stream = Tty()
    p = Progress(400, "replay", stream=stream, clock=lambda: now[0])
    now[0] = 2.0
    p.update(100)
    text = stream.getvalue()
    assert text.startswith("\rreplay [#######---------------------]  25% 100/400 frames ETA 0:06")
    p.close()
    assert stream.getvalue().endswith("\r\x1b[K")


def test_progress_is_plain_in_ci_even_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CI", "true")
    now = [5.0]
    stream = Tty()
    p = Progress(10, "replay", stream=stream, clock=lambda: now[0])
    now[0] = 7.0
    p.update(5)
    assert stream.getvalue() == "replay: 50% (5/10 frames), 0:02 elapsed, 0:02 left\n"


def test_short_or_quiet_runs_show_no_progress() -> None:
    stream = Tty()
    p = Progress(10, "replay", stream=stream, clock=lambda: 0.5, plain=False)
    p.update(5)
    p.close()
    quiet = Progress(10, "replay", stream=stream, clock=lambda: 9.0, enabled=False)
    quiet.update(5)
    quiet.close()
    assert stream.getvalue() == ""


# ---------------------------------------------------------------- tools


@pytest.mark.parametrize("tool", ["replay", "logplot"])
def test_tool_help(tool: str) -> None:
    done = subprocess.run(
        [str(ROOT / "tools" / tool), "--help"], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"usage: {tool}")
    assert "exit status" in done.stdout


def test_read_log_names_the_problem_of_an_unknown_format(tmp_path: Path, db: object) -> None:
    path = tmp_path / "x.trc"
    path.write_text("")
    with pytest.raises(LogError, match=r"\.trc"):
        read_log(path, db)  # type: ignore[arg-type]
    with pytest.raises(LogError, match="unknown log format"):
        read_log(path, db, "mf4")  # type: ignore[arg-type]


def test_columnar_and_line_parsers_agree(tmp_path: Path, db: object) -> None:
    # One extra space after the first line sends the file down the line-by-line path.
    lines = log_lines("paper-circle")
    fast = read_log(DATA / "paper-circle.log", db)  # type: ignore[arg-type]
    slow_path = write(tmp_path, [lines[0] + " ", *lines[1:]])
    slow = read_log(slow_path, db)  # type: ignore[arg-type]
    assert slow.problems == []
    for column in ("time", "frame_id", "extended", "dlc", "data", "line"):
        assert np.array_equal(getattr(fast, column), getattr(slow, column)), column
    assert fast.channel == slow.channel
    assert list(fast.time[:3]) == [split(line)[0] for line in lines[:3]]
    # Two channel names send it down the regular-expression path.
    two = [line.replace(" sil0 ", " can1 ") if i % 2 else line for i, line in enumerate(lines)]
    mixed = read_log(write(tmp_path, two, "two.log"), db)  # type: ignore[arg-type]
    for column in ("time", "frame_id", "extended", "dlc", "data", "line"):
        assert np.array_equal(getattr(fast, column), getattr(mixed, column)), column
    assert mixed.channel[:2] == ["sil0", "can1"]
