# SPDX-License-Identifier: MIT
"""The closed loops around the firmware, sharing all but the clock:
lock-step (:mod:`~mstc.loop.lockstep`: the plant's time is the firmware's,
in memory or through CAN frames) and real time (:mod:`~mstc.loop.realtime`:
the wall clock, against a firmware on its own timer, measured by
:mod:`~mstc.loop.timing`); what a run leaves (:mod:`~mstc.loop.result`)."""
