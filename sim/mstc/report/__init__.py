# SPDX-License-Identifier: MIT
"""What a run leaves behind: outputs on disk, report tables, figures, progress."""
