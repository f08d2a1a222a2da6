# SPDX-License-Identifier: MIT
"""mstc: the plant, the CAN harness and the log tools of the mstc firmware.

Laid out in layers, one folder per feature (docs/architecture.md, "The
Python package"), each importing only from the layers below it:

- :mod:`mstc.model` and :mod:`mstc.errors`, the ground floor: the domain
  types (pose, obstacle, parameters, the step's result, the
  :class:`~mstc.model.Controller` and :class:`~mstc.model.Progress`
  protocols) and every error, derived from :class:`mstc.errors.MstcError`;
- :mod:`mstc.can`: the DBC, the protocol from it, SecOC, the python-can
  interface ``mstc-sil`` and the firmware library's bindings;
  :mod:`mstc.limits`: the parameters' limits table;
- :mod:`mstc.plant`: the kinematic plant, the paper's reference robot, the
  range sensor, scenario files (docs/scenarios.md);
  :mod:`mstc.firmware`: the firmware in process, as ``mstc-fw``, under QEMU;
- :mod:`mstc.loop`: the closed loops, lock-step
  (:func:`~mstc.loop.lockstep.simulate`, in memory or through frames) and
  real time, with its timing;
- :mod:`mstc.logs`: bus logs: one module per format, decoding, replay
  through the firmware, playback onto a bus, MCAP export;
- :mod:`mstc.report`: what a run leaves on disk, the report tables, figures
  and progress bars;
- :mod:`mstc.sweep`: scenario suites and sweeps;
- :mod:`mstc.cli`: the ``mstc`` command, one module per subcommand.
"""

__version__ = "0.1.0"
