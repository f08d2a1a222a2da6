#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Instructions per step by function and by inlined function, from a QEMU
``-d in_asm,exec,nochain`` log of prof_main.c's run (profile.sh): each
translation block's instructions (in_asm, when translated) counted each time
it runs (exec) between prof_begin and prof_end, mapped to the ELF's symbols
(nm) and to inlined source lines (addr2line -i).

    prof.py ELF LOG STEPS PICKLE
"""

import bisect
import collections
import pickle
import re
import subprocess
import sys


def main() -> None:
    elf, log, nsteps, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
    syms = []
    nm = subprocess.run(["arm-none-eabi-nm", "-n", "-S", elf], capture_output=True, text=True)
    for line in nm.stdout.splitlines():
        p = line.split()
        if len(p) == 4 and p[2] in "tTwW":
            syms.append((int(p[0], 16), int(p[1], 16), p[3]))
    syms.sort()
    starts = [s[0] for s in syms]

    def fn(pc: int) -> str:
        i = bisect.bisect_right(starts, pc) - 1
        if i >= 0 and pc < syms[i][0] + syms[i][1]:
            return syms[i][2]
        return f"?{pc:x}"

    begin = next(s[0] for s in syms if s[2] == "prof_begin")
    end = next(s[0] for s in syms if s[2] == "prof_end")
    tb: dict[int, list[int]] = {}
    cur = None
    pcc: collections.Counter[int] = collections.Counter()
    active = False
    re_ins = re.compile(r"^0x([0-9a-f]{8}):")
    re_exec = re.compile(r"^Trace \d+: 0x[0-9a-f]+ \[[0-9a-f]+/([0-9a-f]+)/")
    with open(log, errors="replace") as f:
        for line in f:
            if line.startswith("IN:") or not line.strip():
                cur = None
                continue
            m = re_ins.match(line)
            if m:
                pc = int(m.group(1), 16)
                if cur is None:
                    cur = pc
                    tb[cur] = []
                tb[cur].append(pc)
                continue
            m = re_exec.match(line)
            if m:
                cur = None
                pc = int(m.group(1), 16)
                if pc == begin:
                    active = True
                elif pc == end:
                    active = False
                elif active:
                    for ipc in tb[pc]:
                        pcc[ipc] += 1
    by_fn: collections.Counter[str] = collections.Counter()
    for pc, c in pcc.items():
        by_fn[fn(pc)] += c
    print(f"total per step {sum(pcc.values()) / nsteps:.1f}")
    print("--- by function (out of line)")
    for name, c in by_fn.most_common(60):
        print(f"{c / nsteps:8.1f}  {name}")
    pcs = sorted(pcc)
    a2l = subprocess.run(
        ["arm-none-eabi-addr2line", "-a", "-f", "-i", "-e", elf] + [f"0x{p:x}" for p in pcs],
        capture_output=True,
        text=True,
    ).stdout.splitlines()
    chains: dict[int, list[tuple[str, str]]] = {}
    key = 0
    name = ""
    expect_name = True
    for line in a2l:
        if line.startswith("0x"):
            key = int(line, 16)
            chains[key] = []
            expect_name = True
        elif expect_name:
            name = line
            expect_name = False
        else:
            chains[key].append((name, line.split(" ")[0].split("/")[-1]))
            expect_name = True
    print("--- calls (runs of each function's first instruction)")
    for a, _, name in syms:
        if pcc.get(a):
            print(f"{pcc[a] / nsteps:8.2f}  {name}")
    with open(out, "wb") as fo:
        pickle.dump({"n": nsteps, "pcc": dict(pcc), "chains": chains, "syms": syms}, fo)


if __name__ == "__main__":
    main()
