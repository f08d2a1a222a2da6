# SPDX-License-Identifier: MIT
"""Reading bus logs (mstc.logs.read): every problem reported as path:line:
problem, skipped or kept as documented, never a crash.

Expected values come from hand-made and hand-damaged lines of the committed
logs.
"""

from __future__ import annotations

import random
import re
from pathlib import Path

import can
import numpy as np
import pytest

from logfiles import DATA, Run, index_of, log_lines, split, write
from mstc.errors import LogError
from mstc.logs.framelog import ProblemKind
from mstc.logs.read import read_log

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


def test_read_log_names_the_problem_of_an_unknown_format(tmp_path: Path, db: object) -> None:
    path = tmp_path / "x.trc"
    path.write_text("")
    with pytest.raises(LogError, match=r"\.trc"):
        read_log(path, db)  # type: ignore[arg-type]
    with pytest.raises(LogError, match="unknown log format"):
        read_log(path, db, "mf4")  # type: ignore[arg-type]


def test_the_fast_and_the_line_parser_agree(tmp_path: Path, db: object) -> None:
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
    # Two channel names send it down the line-by-line path too.
    two = [line.replace(" sil0 ", " can1 ") if i % 2 else line for i, line in enumerate(lines)]
    mixed = read_log(write(tmp_path, two, "two.log"), db)  # type: ignore[arg-type]
    for column in ("time", "frame_id", "extended", "dlc", "data", "line"):
        assert np.array_equal(getattr(fast, column), getattr(mixed, column)), column


# ------------------------------------------------ issue 13: bounded, one rule


def test_problems_are_all_counted_and_the_first_ones_kept(tmp_path: Path, db: object) -> None:
    # An unknown identifier at line 5, 5,000 garbage lines from line 11, 11
    # more unknown identifiers after them: the first 20 in file order are kept
    # (the early unknown identifier among them), every one is counted.
    lines = list(log_lines("paper-line")[:600])
    stamp = lines[4].split()[0]
    lines[4] = f"{stamp} sil0 7AB#0011223344556677"
    lines[10:10] = ["junk"] * 5000
    last = lines[-1].split()[0]
    lines += [f"{last} sil0 7AC#00112233445566{i:02X}" for i in range(10)]
    path = write(tmp_path, lines)
    log = read_log(path, db, max_problems=20)  # type: ignore[arg-type]
    assert len(log.problems) == 20
    assert [p.line for p in log.problems] == [5, *range(11, 30)]
    assert log.problems.total == 5011
    assert log.problems.counts == {ProblemKind.MALFORMED: 5000, ProblemKind.UNKNOWN_ID: 11}
    assert len(log) == 600 + 10  # every frame kept


def test_the_cli_keeps_as_many_problems_as_it_prints(
    tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    path = write(tmp_path, [*short_lines[:10], *(["junk"] * 3000), *short_lines[10:]])
    rc, out, err = run_replay("--max-problems", "3", path)
    assert rc == 0 and "bit-exact" in out
    assert err.count(": expected '(time) interface id#data'") == 3
    assert "... and 2,997 more problems (3,000 malformed in all)" in err
    assert re.search(r"log problems\s+3,000\s", out)


def _one_high_id(lines: list[str], at: int) -> list[str]:
    stamp = lines[at].split()[0]
    return [*lines[:at], f"{stamp} sil0 FFF#0011223344556677", *lines[at:]]


def test_a_three_digit_identifier_above_7ff_is_skipped_whatever_the_other_lines(
    tmp_path: Path, short_lines: list[str], db: object
) -> None:
    # Every other line regular (the fast reader), or one other line irregular
    # (the line-by-line reader): the same rule, skipped as not a frame.
    regular = _one_high_id(short_lines, 30)
    irregular = list(regular)
    irregular[60] += " "
    for lines in (regular, irregular):
        log = read_log(write(tmp_path, lines), db)  # type: ignore[arg-type]
        assert [(p.line, p.kind, p.message) for p in log.problems] == [
            (31, ProblemKind.MALFORMED, "standard identifier FFF above 7FF")
        ]
        assert len(log) == len(short_lines)
        assert 0xFFF not in log.frame_id


def asc_of(lines: list[str], tmp_path: Path) -> Path:
    """An ASC file of @p lines (candump -L), written by python-can."""
    src = write(tmp_path, lines, "src.log")
    path = tmp_path / "bus.asc"
    with can.Logger(str(path)) as writer:
        for msg in can.LogReader(str(src)):
            writer.on_message_received(msg)
    return path


def test_asc_lines_python_can_skips_are_reported_like_candump_ones(
    tmp_path: Path, short_lines: list[str], run_replay: Run
) -> None:
    path = asc_of(short_lines, tmp_path)
    text = path.read_text().splitlines()
    first = next(i for i, line in enumerate(text) if "Rx" in line)
    # Damage three frame lines in the middle: garbage, a truncated line, a
    # line the reader's pattern does not take.
    at = first + 40
    text[at] = "hello world"
    text[at + 10] = " 0.400000 1"
    text[at + 20] = text[at + 20].replace(" Rx ", " Qx ")
    path.write_text("\n".join(text) + "\n")
    rc, out, err = run_replay(path)
    where = re.escape(str(path))
    for n, shown in ((at + 1, "hello world"), (at + 11, "0.400000 1"), (at + 21, " Qx ")):
        said = rf"^{where}:{n}: skipped by python-can's ASC reader: '.*{re.escape(shown)}"
        assert re.search(said, err, re.M), err
    assert err.count("skipped by python-can's ASC reader") == 3
    assert rc == 1  # three frames were lost: the firmware answered other inputs


def test_asc_problems_name_the_line(tmp_path: Path, short_lines: list[str], db: object) -> None:
    stamp = short_lines[20].split()[0]
    path = asc_of(
        [*short_lines[:20], f"{stamp} sil0 7AB#0011223344556677", *short_lines[20:]], tmp_path
    )
    n = 1 + next(i for i, line in enumerate(path.read_text().splitlines()) if " 7AB " in line)
    log = read_log(path, db)  # type: ignore[arg-type]
    assert [str(p) for p in log.problems] == [
        f"{path}:{n}: identifier 7AB is not in the DBC: not fed"
    ]


@pytest.mark.parametrize("stamp", ["(1e300)", "(9007199255.000000)", "(-1e300)", "(1e400)"])
def test_an_absurd_time_stamp_is_skipped_as_not_a_frame(
    stamp: str, tmp_path: Path, short_lines: list[str], db: object
) -> None:
    frame = short_lines[50].split()[2]
    path = write(tmp_path, [*short_lines[:50], f"{stamp} sil0 {frame}", *short_lines[50:]])
    log = read_log(path, db)  # type: ignore[arg-type]
    assert [(p.line, p.kind) for p in log.problems] == [(51, ProblemKind.MALFORMED)]
    assert (
        "time stamp" in log.problems[0].message and "9007199254.740992" in log.problems[0].message
    )
    assert len(log) == len(short_lines)
    assert float(abs(log.time).max()) < 2**53 / 1e6
