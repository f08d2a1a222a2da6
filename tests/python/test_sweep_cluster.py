# SPDX-License-Identifier: MIT
"""`mstc sweep --scheduler` on a real Dask cluster: a `dask scheduler` and two
`dask worker` processes on 127.0.0.1, started as docs/sweeps.md starts them.
The expected rows are those of the same sweep on the local pool (every column
but the measured step cost is the same for the same inputs, docs/sweeps.md).

- the cluster gives the local rows, row for row, in the same order;
- a worker killed (SIGKILL) while it holds slices loses no row and
  duplicates none: the scheduler gives its slices to the other worker, and
  runs.csv is the local one."""

from __future__ import annotations

import csv
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from mstc.cli import main
from mstc.sweep.engine import MEASURED_COLUMNS

SUITE = """\
[suite]
name = "cluster"

[family.head_on]
count = {count}
seed = 3
duration = 8.0

[family.cluster]
count = {count}
seed = 2
duration = 8.0
along = [2.0, 2.5]
"""
STRATEGIES = "paper,mstc"


def _sweep(out: Path, suite: Path, lib: Path, *extra: str) -> list[str]:
    """The command of a sweep of @p suite into @p out."""
    return [
        sys.executable,
        "-m",
        "mstc",
        "sweep",
        "--lib",
        str(lib),
        "--strategy",
        STRATEGIES,
        "--gallery",
        "0",
        "-q",
        "--out",
        str(out),
        *extra,
        str(suite),
    ]


def rows(out: Path) -> list[dict[str, str]]:
    """runs.csv without the measured columns."""
    with (out / "runs.csv").open(newline="") as f:
        return [
            {k: v for k, v in r.items() if k not in MEASURED_COLUMNS} for r in csv.DictReader(f)
        ]


@pytest.fixture(scope="module")
def suite(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("suite") / "cluster.toml"
    path.write_text(SUITE.format(count=16))
    return path


@pytest.fixture(scope="module")
def local(tmp_path_factory: pytest.TempPathFactory, suite: Path, sil_lib: Path) -> Path:
    """The sweep on the local pool: the expected rows."""
    out = tmp_path_factory.mktemp("local")
    args = _sweep(out, suite, sil_lib, "--jobs", "2")[3:]
    assert main(args) == 0
    return out


def _written(path: Path) -> int:
    """Rows in @p path so far (a header, then a line a row)."""
    try:
        return max(0, path.read_text().count("\n") - 1)
    except FileNotFoundError:
        return 0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def cluster(sil_lib: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A Dask scheduler and two single-threaded workers on 127.0.0.1, each
    under its nanny (docs/sweeps.md's commands)."""
    dask = Path(sys.executable).with_name("dask")
    if not dask.exists():
        pytest.fail(f"{dask} not found: the Dask tests need distributed (requirements.txt)")
    tmp = tmp_path_factory.mktemp("dask")
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "MSTC_SIL_LIB": str(sil_lib.resolve())}
    log = (tmp / "dask.log").open("w")
    common = ["--no-dashboard"]
    procs = [
        subprocess.Popen(
            [str(dask), "scheduler", "--host", "127.0.0.1", "--port", str(port), *common],
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
            cwd=tmp,
        )
    ]
    try:
        from distributed import Client

        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [str(dask), "worker", address, "--nworkers", "1", "--nthreads", "1", *common],
                    env=env,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    cwd=tmp,
                )
            )
        deadline = time.monotonic() + 90
        while True:
            try:
                with Client(address, timeout="5s") as client:
                    client.wait_for_workers(2, timeout=60)
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.5)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
        log.close()


def test_the_cluster_gives_the_local_rows(
    local: Path,
    suite: Path,
    sil_lib: Path,
    cluster: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    args = _sweep(tmp_path, suite, sil_lib, "--scheduler", cluster)[3:]
    assert main(args) == 0
    assert cluster in capsys.readouterr().out
    assert len(rows(local)) == 2 * 16 * 2
    assert rows(tmp_path) == rows(local)


def test_a_worker_killed_mid_sweep_loses_no_row_and_duplicates_none(
    local: Path, suite: Path, sil_lib: Path, cluster: str, tmp_path: Path
) -> None:
    """Slices of two scenes (--batch 4): 16 of them. Once the first rows are
    in runs.csv, the worker process that holds slices is killed; the sweep
    ends with the local rows, each once."""
    from distributed import Client

    out = tmp_path / "out"
    sweep = subprocess.Popen(
        _sweep(out, suite, sil_lib, "--scheduler", cluster, "--batch", "4"),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    killed: list[tuple[str, int, int]] = []
    try:
        with Client(cluster, timeout="10s") as client:
            pids: dict[str, int] = client.run(os.getpid)
            deadline = time.monotonic() + 120
            while not killed and sweep.poll() is None and time.monotonic() < deadline:
                written = _written(out / "runs.csv")
                busy = [w for w, keys in client.processing().items() if keys and w in pids]
                if written >= 1 and busy:
                    os.kill(pids[busy[0]], signal.SIGKILL)
                    killed.append((busy[0], pids[busy[0]], written))
                time.sleep(0.05)
        output, _ = sweep.communicate(timeout=300)
    finally:
        if sweep.poll() is None:
            sweep.kill()
    assert killed, "no worker held a slice once the first rows were written: nothing was killed"
    assert sweep.returncode == 0, output
    worker, _, written = killed[0]
    total = len(rows(local))
    assert written < total, f"the sweep had ended ({written} rows) when {worker} was killed"
    assert rows(out) == rows(local)
