# SPDX-License-Identifier: MIT
"""mstc: the plant, the CAN harness and the log tools of the mstc firmware.

Laid out by job:

- :mod:`mstc.sim`: the kinematic plant (:mod:`~mstc.sim.plant`), the paper's
  virtual reference robot (:mod:`~mstc.sim.reference`), the range sensor
  (:mod:`~mstc.sim.sensor`), scenario files (:mod:`~mstc.sim.scenario`,
  docs/scenarios.md) and the closed loop (:func:`~mstc.sim.run.simulate`);
- :mod:`mstc.can`: the protocol from the DBC (:mod:`~mstc.can.protocol`), the
  python-can interface ``mstc-sil`` (:mod:`~mstc.can.silbus`) and the
  lock-step controller that drives the firmware through frames
  (:mod:`~mstc.can.lockstep`);
- :mod:`mstc.logs`: bus logs: reading, decoding, replay through the firmware,
  playback onto a bus;
- :mod:`mstc.report`: what a run leaves on disk, the report tables, figures
  and progress;
- :mod:`mstc.cli`: the ``mstc`` command, one module per subcommand.

The firmware's controller is reached through the
:class:`~mstc.controller.Controller` protocol; :mod:`mstc.firmware` holds the
bindings of the firmware library (in-process, ``libmstc_sil.so``). Every error
raised on purpose derives from :class:`mstc.errors.MstcError`.
"""

__version__ = "0.1.0"
