# SPDX-License-Identifier: MIT
"""The CAN side: the protocol from the DBC, the python-can interface
``mstc-sil`` and the lock-step controller."""
