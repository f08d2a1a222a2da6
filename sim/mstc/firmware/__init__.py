# SPDX-License-Identifier: MIT
"""The firmware, reached three ways: its control step in this process
(:mod:`~mstc.firmware.sil`), ``mstc-fw`` as its own process on SocketCAN
(:mod:`~mstc.firmware.process`), and the board images under QEMU
(:mod:`~mstc.firmware.qemu`)."""
