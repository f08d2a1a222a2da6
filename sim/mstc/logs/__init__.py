# SPDX-License-Identifier: MIT
"""Bus logs: reading (candump -L, ASC, BLF), writing candump -L, decoding,
replay through the firmware and playback onto a bus."""
