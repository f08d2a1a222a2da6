# SPDX-License-Identifier: MIT
"""Scenario suites and sweeps (docs/sweeps.md).

- :mod:`~mstc.sweep.suite`: suite files and the seeded scene families they
  generate, written as ordinary scenario files;
- :mod:`~mstc.sweep.metrics`: what one run is judged by (a row of runs.csv);
- :mod:`~mstc.sweep.dwa`: the Dynamic Window Approach, the baseline a user
  would pick instead, behind the same :class:`~mstc.model.Controller`;
- :mod:`~mstc.sweep.engine`: running many scenes, for several strategies, on
  a process pool or a Dask cluster, with resume;
- :mod:`~mstc.sweep.summary`: summary.md, its rates, intervals and figures.
"""
