# SPDX-License-Identifier: MIT
"""Scenario suites and sweeps (docs/sweeps.md).

- :mod:`~mstc.sweep.suite`: suite files and the seeded scene families they
  generate: each scene a pure function of the suite, family, actuator
  profile and index, as a document or as a scenario file;
- :mod:`~mstc.sweep.metrics`: what one run is judged by (a row of runs.csv);
- :mod:`~mstc.sweep.dwa`: the Dynamic Window Approach, the baseline a user
  would pick instead, behind the same :class:`~mstc.model.Controller`;
- :mod:`~mstc.sweep.engine`: a batch of (scene, strategy) jobs run in one
  process, with the batched or the per-scene engine;
- :mod:`~mstc.sweep.plan`: a sweep's runs numbered and cut into slices that
  the workers make, run and send back as rows; resume;
- :mod:`~mstc.sweep.jobs`: any command's tasks on a process pool or a Dask
  cluster, their results in order, a dead worker's tasks run again;
- :mod:`~mstc.sweep.rows`: a CSV of rows written in plan order as they come,
  resumable;
- :mod:`~mstc.sweep.summary`: summary.md, counted as the rows come: rates,
  intervals, exact medians, figures;
- :mod:`~mstc.sweep.folder`, :mod:`~mstc.sweep.spool`: a sweep's folder (one
  sweep at a time, sources.json) and the scenario files it waits to send.
"""
