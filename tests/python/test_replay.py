# SPDX-License-Identifier: MIT
"""``mstc replay``: the committed logs replay bit-exact, and the first difference
is found and shown with its signals.

Expected values come from the logs themselves (their lines, split by hand,
and cantools decoding single frames) and from hand-made changes to them; never
from the replayer's own output.
"""

from __future__ import annotations

import re
from pathlib import Path

import can
import cantools
import pytest

from logfiles import CANDUMP_LINE, DATA, DBC, NAMES, Run, index_of, log_lines, split, write
from mstc.can.protocol import Protocol, e2e_crc
from mstc.logs.read import read_log
from mstc.logs.replay import replay

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


# ------------------------------------------------ issue 13: nothing compared


def other_bus(tmp_path: Path) -> Path:
    """A log of another bus: identifiers the DBC does not have."""
    lines = [
        f"({k * 0.01:.6f}) can1 {0x300 + k % 5:03X}#00112233445566{k % 256:02X}" for k in range(200)
    ]
    return write(tmp_path, lines, "other.log")


def test_a_replay_that_compared_nothing_fails(tmp_path: Path, run_replay: Run) -> None:
    path = other_bus(tmp_path)
    rc, out, err = run_replay("--quiet", "--max-problems", "0", path)
    assert rc == 2
    assert "bit-exact" not in out
    assert re.search(r"compared\s+0\s", out)
    assert f"error: {path}: nothing compared" in err
    assert "--allow-empty" in err


def test_a_replay_that_compared_nothing_passes_when_asked(tmp_path: Path, run_replay: Run) -> None:
    rc, out, err = run_replay(
        "--quiet", "--max-problems", "0", "--allow-empty", other_bus(tmp_path)
    )
    assert rc == 0
    assert "nothing compared" in out
    assert "error" not in err


def test_a_replay_under_another_key_says_the_commands_were_refused(
    tmp_path: Path, run_replay: Run
) -> None:
    """Without the log's key the firmware refuses the log's authenticated
    commands, and the replay says so and names the keys (issue 35: it said
    only DIFFERENT). paper-line.log holds 17 authenticated PARAM_SETs (its
    17 PARAM_AUTH frames), each refused under another key; its own firmware
    refused none (AUTH_STATUS_refused 0 throughout the log)."""
    frames = [split(line) for line in log_lines("paper-line")]
    auths = sum(1 for _, i, _ in frames if i == 0x122)
    assert auths == 17
    other = tmp_path / "other.key"
    other.write_text("00112233445566778899aabbccddeeff\n")
    other.chmod(0o600)
    rc, out, err = run_replay("--quiet", "--key-file", other, DATA / "paper-line.log")
    assert rc == 1
    assert "DIFFERENT" in out
    assert err.splitlines() == [
        f"error: {DATA / 'paper-line.log'}: the firmware refused {auths} of the log's "
        f"authenticated commands (AUTH_STATUS_refused {auths}, the log's 0): it has another key "
        f"than the log's firmware had (the key of {other}); the committed logs under tests/data "
        "are signed with tests/data/test.key: --key-file tests/data/test.key"
    ]


def test_the_float_log_through_the_fixed_build_differs_as_docs_replay_says(
    libs: dict[str, Path], run_replay: Run
) -> None:
    """docs/replay.md's second example, as pasted (issue 35: it made `make`
    fail): the float build's log through the fixed-point build says
    DIFFERENT and exits 1, which the page's `|| test $? -eq 1` expects; the
    difference is the rounding (docs/numerics.md), not the key: nothing is
    refused. Through the float build the same log is bit-exact."""
    key = DATA / "test.key"
    log = DATA / "paper-line.log"
    rc, out, err = run_replay("--lib", libs["float"], "--quiet", "--key-file", key, log, lib=False)
    assert rc == 0 and "DIFFERENT" not in out, out + err
    rc, out, err = run_replay("--lib", libs["fixed"], "--quiet", "--key-file", key, log, lib=False)
    assert rc == 1, out + err
    assert "DIFFERENT" in out
    assert "refused" not in err, err
