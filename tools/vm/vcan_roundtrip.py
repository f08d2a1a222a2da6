# SPDX-License-Identifier: MIT
"""Bare python-can round trips over a SocketCAN interface, per second.

Two ``socketcan`` buses on the same interface, both in this process: one sends
a frame, the other receives it, and the next frame goes only then. The rate is
the floor any lock-step loop over that interface can reach with Python on both
ends, and the reference the HIL bench compares the firmware against.

Run it where the interface exists, e.g.::

    tools/vm/with-vcan -- .venv/bin/python tools/vm/vcan_roundtrip.py --runs 5

It prints one JSON object: the median and every run's rate.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

import can


def round_trips_per_second(tx: can.BusABC, rx: can.BusABC, count: int, timeout_s: float) -> float:
    """Send ``count`` frames on ``tx``, each received on ``rx`` before the next.

    Every received frame is checked against the one sent (ID and bytes).

    :raises RuntimeError: when a frame does not arrive in ``timeout_s`` or
        arrives changed.
    """
    start = time.perf_counter()
    for i in range(count):
        data = i.to_bytes(4, "little") + bytes((0xA5, 0x5A, i & 0xFF, 0x3C))
        tx.send(can.Message(arbitration_id=0x123, data=data, is_extended_id=False))
        got = rx.recv(timeout_s)
        if got is None:
            raise RuntimeError(f"frame {i} not received within {timeout_s} s")
        if got.arbitration_id != 0x123 or bytes(got.data) != data:
            raise RuntimeError(f"frame {i} came back as {got}, sent {data.hex()}")
    return count / (time.perf_counter() - start)


def main(argv: list[str] | None = None) -> int:
    """Command line entry point; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--iface", default="vcan0", help="SocketCAN interface (default: vcan0)")
    parser.add_argument(
        "--count", type=int, default=2000, help="round trips per run (default: 2000)"
    )
    parser.add_argument(
        "--runs", type=int, default=5, help="runs; the median is reported (default: 5)"
    )
    parser.add_argument("--timeout", type=float, default=1.0, help="seconds to wait for one frame")
    args = parser.parse_args(argv)
    if args.count < 1 or args.runs < 1:
        parser.error("--count and --runs must be at least 1")

    tx = can.Bus(interface="socketcan", channel=args.iface)
    rx = can.Bus(interface="socketcan", channel=args.iface)
    try:
        rates = [round_trips_per_second(tx, rx, args.count, args.timeout) for _ in range(args.runs)]
    except RuntimeError as exc:
        print(f"vcan_roundtrip: error: {exc}", file=sys.stderr)
        return 1
    finally:
        tx.shutdown()
        rx.shutdown()
    print(
        json.dumps(
            {
                "iface": args.iface,
                "count": args.count,
                "round_trips_per_s_median": round(statistics.median(rates), 1),
                "round_trips_per_s_runs": [round(r, 1) for r in rates],
            }
        )
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
