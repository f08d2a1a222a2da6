# SPDX-License-Identifier: MIT
"""Flash, RAM and worst-case stack of the board images (``make firmware-budget``).

Usage:
  python -m mstc.bench.budget IMAGE_DIR...          budget report; exit 1 when over budget
  python -m mstc.bench.budget --modules IMAGE_DIR   bytes per module (the size report)

IMAGE_DIR is build/firmware/<board> as `make firmware` leaves it: mstc.elf,
mstc.map, and obj-<numeric>/ with one .su file per object (-fstack-usage).

Budgets (issue 6): flash <= 32 KiB and RAM <= 8 KiB per image. Flash is
.isr_vector + .auth_key + .text + .ARM.* + the .data image; RAM is .data + .bss + the
stack reserved by the linker script (__stack_size), so the stack counts at
its reservation, and the reservation is checked against the worst case below.

Worst-case stack depth, the method:
1. Call graph from the linked image, not from the sources: `objdump -d` of
   mstc.elf; an edge for every `bl`/`blx <sym>` and every branch to the start
   of another function (a tail call). This sees what the compiler really
   emitted (after inlining) and covers newlib, libm and libgcc, for which no
   .su exists. `blx rN` (a call through a pointer) is an unknown edge: it is
   listed, and the result is then a lower bound (none in these images).
2. Frame of each function: from the .su files (GCC's own figure, exact,
   "static" = fixed size) where one exists; otherwise (library code) the
   deepest point of its prologue pushes in the disassembly (push, vpush,
   stmdb sp!, sub sp), marked "~".
3. Depth of a function = its frame + the deepest of its callees; a cycle
   (recursion) makes the depth unbounded and is reported as such.
4. Whole-image worst case = depth(main) + for every interrupt handler in
   the vector table (that is not Default_Handler's alias) its depth plus an
   exception frame (32 bytes; 104 on a core with an FPU, the extended frame
   with lazy stacking, + 4 for alignment), all handlers assumed nested. That
   over-counts (handlers of equal priority cannot nest) but never under-counts.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from mstc.errors import StackUnbounded

# The smallest common STM32F103, the C8: 64 KB of flash and 20 KB of RAM
# (issues 19 and 20: the actuator's prediction and the wheel loop took the
# images past the former 32 KB).
FLASH_BUDGET = 64 * 1024
RAM_BUDGET = 16 * 1024
FLASH_SECTIONS = (".isr_vector", ".auth_key", ".text", ".ARM.extab", ".ARM.exidx")
RAM_SECTIONS = (".data", ".bss")
CROSS = os.environ.get("CROSS_COMPILE", "arm-none-eabi-")


# ----------------------------------------------------------------- map file
@dataclass
class Piece:
    out: str  # output section
    module: str
    size: int


def _module(path: str, obj_dir: str) -> str:
    m = re.search(r"lib(c_nano|c|m|gcc|nosys)\.a\(", path)
    if m:
        return {"c_nano": "libc", "c": "libc", "m": "libm", "gcc": "libgcc", "nosys": "libnosys"}[
            m.group(1)
        ]
    if "/gen/" in path or path.startswith("gen/"):
        return "gen (vector table)"
    rel = path.split("/obj-", 1)[1].split("/", 1)[1] if "/obj-" in path else path
    parts = rel.split("/")
    return "/".join(parts[:2]) if len(parts) > 2 else parts[0]


def parse_map(map_path: Path) -> tuple[list[Piece], dict[str, int]]:
    """Input-section pieces by output section, and the linker symbols."""
    text = map_path.read_text()
    body = text.split("Linker script and memory map", 1)[1]
    pieces: list[Piece] = []
    symbols: dict[str, int] = {}
    out = None
    pending = None  # an input section name whose numbers are on the next line
    for line in body.splitlines():
        m = re.match(r"^(\.[\w.]+)\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)", line)
        if m:
            out = m.group(1)
            continue
        if re.match(r"^\.[\w.]+\s*$", line):
            out = line.strip()
            continue
        m = re.match(r"^\s+0x([0-9a-f]+)\s+(__stack_size|__stack_top|__stack_limit)\s*=", line)
        if m:
            symbols[m.group(2)] = int(m.group(1), 16)
            continue
        m = re.match(r"^ (\S+)\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$", line)
        if m and not m.group(1).startswith("*fill*"):
            pieces.append(Piece(out or "", _module(m.group(4), ""), int(m.group(3), 16)))
            pending = None
            continue
        m = re.match(r"^ (\S+)\s*$", line)
        if m and not line.startswith(" *"):
            pending = m.group(1)
            continue
        m = re.match(r"^\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$", line)
        if m and pending is not None:
            pieces.append(Piece(out or "", _module(m.group(3), ""), int(m.group(2), 16)))
            pending = None
            continue
        m = re.match(r"^ \*fill\*\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)", line)
        if m:
            pieces.append(Piece(out or "", "(alignment)", int(m.group(2), 16)))
    return pieces, symbols


@dataclass
class Sizes:
    flash: int
    data: int
    bss: int
    stack_reserved: int
    by_module: dict[str, list[int]]  # module -> [flash, data, bss]

    @property
    def ram(self) -> int:
        return self.data + self.bss + self.stack_reserved


def sizes(image_dir: Path) -> Sizes:
    pieces, symbols = parse_map(image_dir / "mstc.map")
    by_module: dict[str, list[int]] = {}
    flash = data = bss = 0
    for p in pieces:
        row = by_module.setdefault(p.module, [0, 0, 0])
        if p.out in FLASH_SECTIONS:
            row[0] += p.size
            flash += p.size
        elif p.out == ".data":
            row[0] += p.size  # its initial values live in flash
            row[1] += p.size
            flash += p.size
            data += p.size
        elif p.out == ".bss":
            row[2] += p.size
            bss += p.size
    return Sizes(flash, data, bss, symbols.get("__stack_size", 0), by_module)


def module_report(image_dir: Path, board: str, numeric: str) -> str:
    s = sizes(image_dir)
    lines = [
        f"size by module: {board} ({numeric}), {image_dir / 'mstc.elf'}",
        f"{'module':<22}{'flash':>8}{'data':>8}{'bss':>8}",
    ]
    for mod, (fl, da, bs) in sorted(s.by_module.items(), key=lambda kv: -kv[1][0] - kv[1][2]):
        if fl or da or bs:
            lines.append(f"{mod:<22}{fl:>8}{da:>8}{bs:>8}")
    lines.append(f"{'total':<22}{s.flash:>8}{s.data:>8}{s.bss:>8}")
    lines.append(
        f"flash {s.flash} B of {FLASH_BUDGET}; RAM {s.ram} B of {RAM_BUDGET} "
        f"(data {s.data} + bss {s.bss} + stack reserved {s.stack_reserved})"
    )
    return "\n".join(lines)


# ------------------------------------------------------------- stack depth
@dataclass
class Func:
    name: str
    addr: int
    frame: int = 0
    exact: bool = False
    dynamic: bool = False
    calls: set[str] = field(default_factory=set)
    indirect: bool = False


BRANCH = re.compile(
    r"^\s*[0-9a-f]+:\s+(b|bl|blx|b\.w|b\.n|b(?:eq|ne|cs|cc|hs|lo|mi|pl|vs|vc|hi|ls|ge|lt|gt|le)"
    r"(?:\.w|\.n)?)\s+([0-9a-f]+)\s+<([^>+]+)(\+0x[0-9a-f]+)?>"
)
INDIRECT = re.compile(r"^\s*[0-9a-f]+:\s+blx\s+r\d+")
FUNC = re.compile(r"^([0-9a-f]{8}) <([^>]+)>:$")


def _reglist_bytes(text: str, unit: int) -> int:
    n = 0
    for part in text.strip("{} ").split(","):
        part = part.strip()
        m = re.fullmatch(r"[rsd](\d+)-[rsd](\d+)", part)
        if m:
            n += int(m.group(2)) - int(m.group(1)) + 1
        elif part:
            n += 1
    return n * unit


def disassemble(elf: Path) -> dict[str, Func]:
    out = subprocess.run(
        [CROSS + "objdump", "-d", "--no-show-raw-insn", str(elf)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    funcs: dict[str, Func] = {}
    cur: Func | None = None
    depth = 0
    for line in out.splitlines():
        m = FUNC.match(line)
        if m:
            cur = funcs.setdefault(m.group(2), Func(m.group(2), int(m.group(1), 16)))
            depth = 0
            continue
        if cur is None or not line.strip():
            continue
        ins = line.split("\t")
        op = ins[1].strip() if len(ins) > 1 else ""
        args = ins[2].strip() if len(ins) > 2 else ""
        # Frame estimate: running sum of pushes and explicit sp decrements.
        if op in ("push", "push.w", "stmdb") and (op != "stmdb" or args.startswith("sp!")):
            depth += _reglist_bytes(args.split("!", 1)[-1].strip(", "), 4)
        elif op == "vpush":
            unit = 8 if "d" in args else 4
            depth += _reglist_bytes(args, unit)
        elif op in ("sub", "sub.w", "subw") and re.match(r"sp,\s*(sp,\s*)?#\d+", args):
            depth += int(args.rsplit("#", 1)[1].split()[0])
        elif op in ("pop", "pop.w", "vpop", "add", "add.w", "addw", "ldmia.w", "ldmia"):
            pass  # the peak is what counts; epilogues come after it
        cur.frame = max(cur.frame, depth)
        b = BRANCH.match(line)
        if b:
            target, offset = b.group(3), b.group(4)
            if b.group(1) in ("bl", "blx"):
                cur.calls.add(target)
            elif offset is None and target != cur.name:
                cur.calls.add(target)  # tail call into another function
        elif INDIRECT.match(line):
            cur.indirect = True
    return funcs


def read_su(obj_dir: Path, funcs: dict[str, Func]) -> None:
    for su in obj_dir.rglob("*.su"):
        for line in su.read_text().splitlines():
            parts = line.split("\t")
            if len(parts) < 3:
                continue
            name = parts[0].rsplit(":", 1)[-1]
            size = int(parts[1])
            kind = parts[2]
            f = funcs.get(name)
            if f is None:
                continue  # inlined everywhere or removed by --gc-sections
            if not f.exact or size > f.frame:
                f.frame = size
            f.exact = True
            f.dynamic = f.dynamic or kind.startswith("dynamic")


def depth_of(
    name: str, funcs: dict[str, Func], memo: dict[str, tuple[int, list[str]]], stack: list[str]
) -> tuple[int, list[str]]:
    if name in memo:
        return memo[name]
    if name in stack:
        raise StackUnbounded(" -> ".join(stack[stack.index(name) :] + [name]))
    f = funcs.get(name)
    if f is None:
        return 0, [name + " (?)"]
    stack.append(name)
    best, chain = 0, []
    for callee in sorted(f.calls):
        d, c = depth_of(callee, funcs, memo, stack)
        if d > best:
            best, chain = d, c
    stack.pop()
    memo[name] = (f.frame + best, [name] + chain)
    return memo[name]


def vector_handlers(elf: Path) -> list[str]:
    """Defined handlers: strong symbols named *_Handler other than the
    Default_Handler aliases."""
    out = subprocess.run(
        [CROSS + "nm", str(elf)], check=True, capture_output=True, text=True
    ).stdout
    addr: dict[str, str] = {}
    strong: set[str] = set()
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[2].endswith("Handler"):
            addr[parts[2]] = parts[0]
            if parts[1] in "Tt":
                strong.add(parts[2])
    default = addr.get("Default_Handler")
    return sorted(
        n for n in strong if n != "Reset_Handler" and (n == "Default_Handler" or addr[n] != default)
    )


def has_fpu(elf: Path) -> bool:
    out = subprocess.run(
        [CROSS + "readelf", "-A", str(elf)], check=True, capture_output=True, text=True
    ).stdout
    return "Tag_FP_arch" in out


@dataclass
class StackReport:
    main: int
    main_chain: list[str]
    step: int
    step_chain: list[str]
    handlers: list[tuple[str, int]]
    exc_frame: int
    worst: int
    inexact: list[str]
    indirect: list[str]
    dynamic: list[str]
    frames: dict[str, str]  # name -> "N" (from .su) or "~N" (from the disassembly)


def stack_report(image_dir: Path) -> StackReport:
    elf = image_dir / "mstc.elf"
    funcs = disassemble(elf)
    objs = sorted(image_dir.glob("obj-*"), key=lambda p: p.stat().st_mtime)
    if objs:
        read_su(objs[-1], funcs)
    memo: dict[str, tuple[int, list[str]]] = {}
    main, main_chain = depth_of("main", funcs, memo, [])
    step, step_chain = (
        depth_of("app_control_tick", funcs, memo, []) if "app_control_tick" in funcs else (0, [])
    )
    exc = 104 + 4 if has_fpu(elf) else 32
    handlers = []
    for h in vector_handlers(elf):
        d, _ = depth_of(h, funcs, memo, [])
        handlers.append((h, d))
    worst = main + sum(d + exc for _, d in handlers)
    reach = {n for n in memo}
    return StackReport(
        main,
        main_chain,
        step,
        step_chain,
        handlers,
        exc,
        worst,
        sorted(n for n in reach if n in funcs and not funcs[n].exact and funcs[n].frame),
        sorted(n for n in reach if n in funcs and funcs[n].indirect),
        sorted(n for n in reach if n in funcs and funcs[n].dynamic),
        {n: (str(f.frame) if f.exact else f"~{f.frame}") for n, f in funcs.items()},
    )


def _chain(chain: list[str], frames: dict[str, str]) -> str:
    return " -> ".join(f"{n} {frames.get(n, '?')}" for n in chain)


def budget_report(dirs: list[Path]) -> int:
    failed = False
    for d in dirs:
        if not (d / "mstc.elf").exists():
            print(f"{d}: no mstc.elf: build it first (make firmware BOARD={d.name})")
            failed = True
            continue
        s = sizes(d)
        try:
            st = stack_report(d)
        except StackUnbounded as e:
            print(f"{d.name}: stack depth unbounded, recursion: {e}")
            failed = True
            continue
        numeric = (d / "numeric.txt").read_text().strip() if (d / "numeric.txt").exists() else "?"
        ok_flash = s.flash <= FLASH_BUDGET
        ok_ram = s.ram <= RAM_BUDGET
        ok_stack = st.worst <= s.stack_reserved
        print(f"{d.name} ({numeric})")
        print(f"  flash  {s.flash:6d} B  budget {FLASH_BUDGET}  {'ok' if ok_flash else 'OVER'}")
        print(
            f"  RAM    {s.ram:6d} B  budget {RAM_BUDGET}  {'ok' if ok_ram else 'OVER'}"
            f"  (data {s.data} + bss {s.bss} + stack reserved {s.stack_reserved})"
        )
        print(
            f"  stack  {st.worst:6d} B  reserved {s.stack_reserved}  "
            f"{'ok' if ok_stack else 'OVER'}  (main {st.main} + "
            + " + ".join(f"{h} {n}+{st.exc_frame}" for h, n in st.handlers)
            + ")"
        )
        print("  deepest path from main, frame bytes each (~: from the disassembly):")
        print(f"    {_chain(st.main_chain, st.frames)}")
        print(f"  control step (app_control_tick) {st.step} B:")
        print(f"    {_chain(st.step_chain, st.frames)}")
        if st.indirect:
            print(f"  calls through pointers (not followed): {', '.join(st.indirect)}")
        if st.dynamic:
            print(f"  dynamic frames (alloca/VLA): {', '.join(st.dynamic)}")
        if st.inexact:
            print(f"  frames from the disassembly (no .su): {len(st.inexact)} library functions")
        failed = failed or not (ok_flash and ok_ram and ok_stack)
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    argv = ["mstc.bench.budget", *(sys.argv[1:] if argv is None else argv)]
    if len(argv) >= 2 and argv[1] == "--modules":
        if len(argv) != 3:
            print(__doc__.split("\n\n")[1], file=sys.stderr)
            return 2
        d = Path(argv[2])
        board = d.name
        numeric = (d / "numeric.txt").read_text().strip() if (d / "numeric.txt").exists() else "?"
        print(module_report(d, board, numeric))
        return 0
    if len(argv) < 2 or argv[1].startswith("-"):
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    return budget_report([Path(a) for a in argv[1:]])


if __name__ == "__main__":
    sys.exit(main())
