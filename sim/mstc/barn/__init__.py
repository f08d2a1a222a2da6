# SPDX-License-Identifier: MIT
"""BARN, the Benchmark for Autonomous Robot Navigation (docs/barn.md): its
worlds (:mod:`mstc.barn.worlds`, the data in ``data/``), runs judged as the
benchmark judges them (:mod:`mstc.barn.run`) and what ``mstc barn`` makes of
them (:mod:`mstc.barn.summary`)."""
