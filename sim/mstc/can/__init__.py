# SPDX-License-Identifier: MIT
"""What speaks CAN: the DBC and its value tables (:mod:`~mstc.can.dbc`), the
protocol from it (:mod:`~mstc.can.protocol`), authenticated commands
(:mod:`~mstc.can.secoc`), and the python-can interface ``mstc-sil``
(:mod:`~mstc.can.silbus`) with the firmware library's bindings
(:mod:`~mstc.can.library`), and the host's end of the vcan VM's bridge
(:mod:`~mstc.can.vmbridge`). It imports nothing of the package above the
ground floor (:mod:`mstc.model`, :mod:`mstc.errors`)."""
