# SPDX-License-Identifier: MIT
"""The benchmarks of ``make bench`` (docs/performance.md), one module each, run
as ``python -m mstc.bench.<name>``: :mod:`~mstc.bench.ctl_step` (the control
step on Cortex-M under QEMU and on the host: the report of the C benchmark in
tools/bench), :mod:`~mstc.bench.canbus` (through frames in process and over
vcan), :mod:`~mstc.bench.realtime`, :mod:`~mstc.bench.replay`,
:mod:`~mstc.bench.sweep`; the board images' budgets
(:mod:`~mstc.bench.budget`) and smoke test (:mod:`~mstc.bench.qemu_smoke`);
the C benchmark's scenarios (:mod:`~mstc.bench.scenarios`); and their
sections of docs/performance.md (:mod:`~mstc.bench.doc`). They measure the
source tree (its scenarios, builds and documents), not an installed package.
"""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
"""The repository the benchmarks measure."""
