# SPDX-License-Identifier: MIT
"""The layer under `mstc sweep` that another command can use as it is
(mstc.sweep.jobs, mstc.sweep.rows), on a toy work whose results are known
without it: a task is a tuple of integers, its result their squares.

- run_tasks emits every result once, in the order of the tasks, though they
  finish out of order;
- a task that kills its worker process is split until the one run that
  does is found: that run's result is the work's `crashed`, the others'
  are their squares; a worker killed from outside loses no result;
- a RowFile writes rows in position order as they come and, resuming,
  keeps the rows it is told to, once each, in order, copying them back among
  the new ones, from the file and from an interrupted resume's file alike."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from contextlib import closing
from dataclasses import dataclass
from pathlib import Path

import pytest

from mstc.sweep.jobs import DIED, run_tasks
from mstc.sweep.rows import RowFile

Task = tuple[int, ...]


@dataclass(frozen=True)
class Squares:
    """The toy work. A task holding @p die kills its worker (exit status 3,
    as a crash in a C library would); a task holding @p stall waits until
    @p gate exists, having written its worker's pid into @p pid; every task
    but the first sleeps @p slow seconds."""

    die: int = -1
    stall: int = -1
    pid: str = ""
    gate: str = ""
    slow: float = 0.0
    """Seconds every task but the first (0, ...) takes."""

    def __call__(self, task: Task) -> list[int | str]:
        if self.die in task:
            os._exit(3)
        if task and task[0]:
            time.sleep(self.slow)
        if self.stall in task:
            Path(self.pid).write_text(str(os.getpid()))
            while not Path(self.gate).exists():
                time.sleep(0.01)
        # Later tasks first: the first task of every three sleeps longest.
        time.sleep(0.02 * (2 - task[0] % 3) if task else 0.0)
        return [x * x for x in task]

    def split(self, task: Task) -> list[Task]:
        half = len(task) // 2
        return [task[:half], task[half:]] if len(task) > 1 else []

    def crashed(self, task: Task, why: str) -> list[int | str]:
        return [f"{task[0]}: {why}"]


TASKS = [tuple(range(i, i + 4)) for i in range(0, 40, 4)]


def run(work: Squares, tasks: list[Task]) -> list[tuple[Task, list[int | str]]]:
    emitted: list[tuple[Task, list[int | str]]] = []
    run_tasks(tasks, work, lambda task, result: emitted.append((task, result)), workers=2)
    return emitted


def test_results_come_once_each_in_the_order_of_the_tasks() -> None:
    emitted = run(Squares(), TASKS)
    assert [task for task, _ in emitted] == TASKS
    assert [r for _, result in emitted for r in result] == [x * x for x in range(40)]


def test_a_task_that_kills_its_worker_is_split_down_to_the_run_that_does() -> None:
    emitted = run(Squares(die=13), TASKS)
    results = [r for _, result in emitted for r in result]
    want: list[int | str] = [x * x for x in range(40)]
    want[13] = f"13: {DIED}"
    assert results == want
    # The task (12, 13, 14, 15) was split: halves, then quarters around 13.
    assert [task for task, _ in emitted][3:7] == [(12,), (13,), (14, 15)] + [TASKS[4]]


def test_a_worker_killed_from_outside_loses_no_result(tmp_path: Path) -> None:
    """The worker running task 20-23 is killed while it runs it: every
    task still comes once, with its squares."""
    pid, gate = tmp_path / "pid", tmp_path / "gate"

    def kill() -> None:
        while not pid.exists() or not pid.read_text():
            time.sleep(0.01)
        os.kill(int(pid.read_text()), signal.SIGKILL)
        gate.touch()  # the run again of the task goes through

    killer = threading.Thread(target=kill)
    killer.start()
    emitted = run(Squares(stall=21, pid=str(pid), gate=str(gate)), TASKS)
    killer.join()
    assert [task for task, _ in emitted] == TASKS
    assert [r for _, result in emitted for r in result] == [x * x for x in range(40)]


def test_an_interrupt_stops_the_workers_at_once() -> None:
    """Ctrl-C (SIGINT to the caller alone) once the first result came: the
    caller ends within seconds, not after the 60 s tasks its two workers
    hold and the ones queued for them."""
    here = Path(__file__).parent
    code = (
        f"import sys; sys.path.insert(0, {str(here)!r})\n"
        "from test_sweep_jobs import Squares\n"
        "from mstc.sweep.jobs import run_tasks\n"
        "run_tasks([(i,) for i in range(8)], Squares(slow=60.0),"
        " lambda task, result: print('emitted', task, flush=True), workers=2)\n"
    )
    child = subprocess.Popen(
        [sys.executable, "-c", code],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        assert child.stdout is not None
        assert child.stdout.readline() == "emitted (0,)\n"
        time.sleep(0.5)  # the workers are in their 60 s tasks
        child.send_signal(signal.SIGINT)
        assert child.wait(timeout=30) != 0
    finally:
        if child.poll() is None:
            child.kill()


COLUMNS = ("key", "value")


def _keep_even(row: dict[str, str]) -> int | None:
    """Keep the rows of even keys (their key is their position)."""
    key = int(row["key"])
    return key if key % 2 == 0 else None


def test_a_row_file_is_written_as_the_rows_come(tmp_path: Path) -> None:
    path = tmp_path / "runs.csv"
    with closing(RowFile(path, COLUMNS)) as table:
        table.write([(0, ("0", "a")), (1, ("1", "b,c"))])
        assert path.read_text() == 'key,value\n0,a\n1,"b,c"\n'  # flushed
        table.write([(2, ("2", "d"))])
        assert table.finish() == []
    assert path.read_text() == 'key,value\n0,a\n1,"b,c"\n2,d\n'


def test_resuming_keeps_the_rows_kept_once_each_in_order(tmp_path: Path) -> None:
    """The file has rows 0-5 out of order, 4 twice, a damaged line and one
    cut short; an interrupted resume left rows 6 and 8 in its resume file.
    Resuming keeps 0, 2, 4, 6, 8 (each once) and runs 1, 3, 5, 7, 9: the
    file ends with the ten rows in order."""
    path = tmp_path / "runs.csv"
    path.write_text("key,value\n2,old2\n0,old0\n4,old4\n1,old1\n4,again4\n5\n3,old3\n6,cut")
    (tmp_path / ".runs.csv.resume").write_text("key,value\n6,old6\n8,old8\n")
    with closing(RowFile(path, COLUMNS, keep=_keep_even)) as table:
        assert table.kept.tolist() == [0, 2, 4, 6, 8]
        assert path.read_text() == "key,value\n"
        assert table.copy_kept(1) == [["0", "old0"]]  # before the first row to make
        assert path.read_text() == "key,value\n0,old0\n"
        copied = table.write([(1, ("1", "new1")), (3, ("3", "new3"))])
        assert copied == [["2", "old2"]]
        copied = table.write([(5, ("5", "new5")), (7, ("7", "new7")), (9, ("9", "new9"))])
        assert copied == [["4", "old4"], ["6", "old6"], ["8", "old8"]]
        assert table.finish() == []
    want = [f"{k},{'old' if k % 2 == 0 else 'new'}{k}" for k in range(10)]
    assert path.read_text().splitlines() == ["key,value", *want]
    assert not (tmp_path / ".runs.csv.resume").exists()


def test_an_interrupted_resume_resumes(tmp_path: Path) -> None:
    """Interrupted after writing new row 1 (and copying 0 back), a resume
    finds rows 0 and 2 in its resume file, 0 and 1 in the file: it keeps
    0, 1 and 2 once each (here every row is good)."""
    path = tmp_path / "runs.csv"
    path.write_text("key,value\n0,a\n1,b\n2,c\n")
    table = RowFile(path, COLUMNS, keep=_keep_even)
    table.write([(1, ("1", "B"))])
    table.close()  # interrupted
    assert path.read_text() == "key,value\n0,a\n1,B\n"

    def keep_all(row: dict[str, str]) -> int | None:
        return int(row["key"])

    with closing(RowFile(path, COLUMNS, keep=keep_all)) as again:
        assert again.kept.tolist() == [0, 1, 2]
        assert again.finish() == [["0", "a"], ["1", "B"], ["2", "c"]]
    assert path.read_text() == "key,value\n0,a\n1,B\n2,c\n"


def test_a_file_of_other_columns_is_not_resumed(tmp_path: Path) -> None:
    path = tmp_path / "runs.csv"
    path.write_text("key,other\n0,a\n")
    with closing(RowFile(path, COLUMNS, keep=_keep_even)) as table:
        assert table.kept.tolist() == []
        table.finish()
    assert path.read_text() == "key,value\n"


@pytest.mark.parametrize("workers", [1, 3])
def test_run_tasks_takes_the_tasks_as_it_needs_them(workers: int) -> None:
    """A generator of 50 tasks is not read ahead of the results by more
    than the window (IN_FLIGHT + WAITING a worker)."""
    from mstc.sweep.jobs import IN_FLIGHT, WAITING

    taken = 0
    ahead: list[int] = []

    def tasks():  # type: ignore[no-untyped-def]
        nonlocal taken
        for i in range(50):
            taken += 1
            yield (i,)

    def emit(task: Task, result: list[int | str]) -> None:
        ahead.append(taken - (task[0] + 1))

    run_tasks(tasks(), Squares(), emit, workers=workers)
    assert len(ahead) == 50 and max(ahead) <= workers * (IN_FLIGHT + WAITING)
