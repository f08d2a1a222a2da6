# SPDX-License-Identifier: MIT
"""Bus logs: one module per format, its reader and writer together
(:mod:`~mstc.logs.candump`, :mod:`~mstc.logs.asc`, :mod:`~mstc.logs.blf`, as
python-can's ``can/io``), what they read into (:mod:`~mstc.logs.framelog`)
and the reader that picks one (:mod:`~mstc.logs.read`); decoding
(:mod:`~mstc.logs.decode`), replay through the firmware
(:mod:`~mstc.logs.replay`), playback onto a bus (:mod:`~mstc.logs.play`) and
MCAP export (:mod:`~mstc.logs.export`)."""
