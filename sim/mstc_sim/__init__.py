# SPDX-License-Identifier: MIT
"""mstc_sim: the kinematic plant of mstc.

A differential-drive robot (:mod:`~mstc_sim.plant`), the paper's virtual
reference robot (:mod:`~mstc_sim.reference`) and a range sensor
(:mod:`~mstc_sim.sensor`) around the firmware's controller, reached through the
:class:`~mstc_sim.controller.Controller` protocol (in-process:
:mod:`~mstc_sim.firmware`). Scenarios are TOML files
(:mod:`~mstc_sim.scenario`, docs/scenarios.md); :func:`~mstc_sim.run.simulate`
closes the loop and ``python -m mstc_sim run`` writes events, traces and figures.
"""
