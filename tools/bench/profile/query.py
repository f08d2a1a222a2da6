#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Queries of a profile (prof.py's pickle), instructions per step:

query.py PICKLE line [N]       by source line of the innermost function
                               that is not a num_* helper
query.py PICKLE incl [N]       inclusive, by inlined function
query.py PICKLE file:F.c [N]   by line of file F.c
query.py PICKLE files          by file of the out-of-line function
"""

import collections
import pickle
import sys

HELPERS = ("num_", "in_mask", "oset_distance", "oset_within", "since", "within")


def main() -> None:
    with open(sys.argv[1], "rb") as f:
        d = pickle.load(f)
    n = d["n"]
    mode = sys.argv[2]
    top = int(sys.argv[3]) if len(sys.argv) > 3 else 80
    c: collections.Counter[object] = collections.Counter()
    for pc, cnt in d["pcc"].items():
        ch = d["chains"].get(pc) or [("?", "?")]
        if mode == "line":
            c[next(((f, ln) for f, ln in ch if not f.startswith(HELPERS)), ch[-1])] += cnt
        elif mode == "incl":
            for f in {f for f, _ in ch}:
                c[f] += cnt
        elif mode == "files":
            c[ch[-1][1].split(":")[0]] += cnt
        elif mode.startswith("file:"):
            hit = next(((f, ln) for f, ln in ch if ln.startswith(mode[5:])), None)
            if hit:
                c[hit] += cnt
    for k, v in c.most_common(top):
        print(f"{v / n:8.1f}  {k}")


if __name__ == "__main__":
    main()
