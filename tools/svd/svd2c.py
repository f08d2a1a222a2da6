#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""svd2c: register header and vector table for a board port, from a vendor SVD.

Usage: svd2c.py CONFIG.json SVD_DIR OUT_DIR

Reads the board's configuration (hal/<board>/svd.json: which SVD file, which
peripherals under which C type name, register arrays), parses the SVD with the
standard library only, and writes two files into OUT_DIR:

- ``stm32_regs.h``: IRQ numbers and handler prototypes of every interrupt in
  the SVD; for each configured type a ``<TYPE>_TypeDef`` struct of
  ``volatile`` registers at the SVD's offsets (gaps padded, each offset
  checked by a ``_Static_assert``), ``<TYPE>_<REG>_<FIELD>_Pos``/``_Msk``
  macros of its bit fields, and one ``<INSTANCE>`` pointer macro per
  peripheral;
- ``stm32_vectors.c``: the vector table (initial stack pointer, the ARMv7-M
  system exceptions, then one entry per IRQ number), every handler a weak
  alias of ``Default_Handler``, as CMSIS startup files do (it calls
  ``stm32_unhandled()``, hal/stm32/startup.c).

The output depends only on its inputs (no dates, no paths), so the same SVD
and configuration always give the same bytes.

Normalisation, so that the shared drivers (hal/stm32/) compile against either
board's header:
- a register name loses the prefix ``<groupName>_`` (ST's F1 SVD calls
  CAN registers ``CAN_MCR``, the F4 one ``MCR``) and any prefix listed under
  ``strip_prefix``; ``rename`` maps names (``CCMR1_Output`` -> ``CCMR1``);
- registers with ``alternateRegister`` (a second view of the same offset)
  are skipped;
- several peripherals may share one type: the struct is the union of their
  registers by offset (two names at one offset is an error), fields come from
  the first peripheral that defines them;
- ``add_fields`` adds fields the SVD lacks, citing the reference manual;
- an interrupt's handler is its name without a trailing ``_IRQ`` plus
  ``_IRQHandler``; when two names share one number the name from a
  configured peripheral wins (F1: ``CAN1_RX0`` over the USB view).
"""

from __future__ import annotations

import json
import re
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class Field:
    name: str
    pos: int
    width: int
    desc: str


@dataclass
class Register:
    name: str
    offset: int
    size: int  # bits
    desc: str
    fields: list[Field] = field(default_factory=list)


def _int(text: str | None, default: int = 0) -> int:
    if text is None:
        return default
    text = text.strip().lower()
    if text.startswith("#"):  # SVD binary literal
        return int(text[1:], 2)
    return int(text, 0)


def _desc(el: ET.Element) -> str:
    text = " ".join((el.findtext("description") or "").split())
    return text.replace("*/", "* /")[:70]


def _fields(reg: ET.Element) -> list[Field]:
    out = []
    for f in reg.iter("field"):
        name = f.findtext("name", "").strip()
        if f.find("bitOffset") is not None:
            pos, width = _int(f.findtext("bitOffset")), _int(f.findtext("bitWidth"), 1)
        elif f.find("lsb") is not None:
            pos = _int(f.findtext("lsb"))
            width = _int(f.findtext("msb")) - pos + 1
        else:  # bitRange "[msb:lsb]"
            m = re.fullmatch(r"\[(\d+):(\d+)\]", f.findtext("bitRange", "").strip())
            if not m:
                raise SystemExit(f"svd2c: field {name}: no bit position")
            pos = int(m.group(2))
            width = int(m.group(1)) - pos + 1
        out.append(Field(name, pos, width, _desc(f)))
    return out


class Svd:
    def __init__(self, path: Path):
        self.root = ET.parse(path).getroot()
        self.name = self.root.findtext("name", "").strip()
        self.version = self.root.findtext("version", "").strip()
        self.periph = {p.findtext("name", "").strip(): p for p in self.root.iter("peripheral")}

    def registers(self, pname: str, strip: list[str], rename: dict[str, str]) -> list[Register]:
        p = self.periph[pname]
        base = p
        if p.find("registers") is None and p.get("derivedFrom"):
            base = self.periph[p.get("derivedFrom", "")]
        group = (p.findtext("groupName") or base.findtext("groupName") or "").strip()
        prefixes = [group + "_"] if group else []
        prefixes += strip
        regs = []
        for r in base.find("registers").iter("register"):
            if r.find("alternateRegister") is not None:
                continue
            if r.find("dim") is not None:
                raise SystemExit(f"svd2c: {pname}: <dim> registers are not supported")
            name = r.findtext("name", "").strip()
            for pre in prefixes:
                if name.startswith(pre):
                    name = name[len(pre) :]
                    break
            name = rename.get(name, name)
            size = _int(r.findtext("size"), _int(self.root.findtext("size"), 32))
            regs.append(
                Register(name, _int(r.findtext("addressOffset")), size, _desc(r), _fields(r))
            )
        return regs

    def base_address(self, pname: str) -> int:
        return _int(self.periph[pname].findtext("baseAddress"))

    def interrupts(self, preferred: set[str]) -> dict[int, str]:
        found: dict[int, tuple[bool, str]] = {}
        for pname, p in self.periph.items():
            for irq in p.findall("interrupt"):
                num = _int(irq.findtext("value"))
                name = re.sub(r"_IRQ$", "", irq.findtext("name", "").strip())
                pref = pname in preferred
                if num not in found or (pref and not found[num][0]):
                    found[num] = (pref, name)
        return {n: name for n, (_, name) in sorted(found.items())}


# ARMv7-M system exceptions 2..15 (ARMv7-M ARM B1.5.2); None: reserved.
SYSTEM_HANDLERS = [
    "NMI_Handler",
    "HardFault_Handler",
    "MemManage_Handler",
    "BusFault_Handler",
    "UsageFault_Handler",
    None,
    None,
    None,
    None,
    "SVC_Handler",
    "DebugMon_Handler",
    None,
    "PendSV_Handler",
    "SysTick_Handler",
]

CTYPE = {8: "uint8_t", 16: "uint16_t", 32: "uint32_t"}


def _struct(tname: str, regs: list[Register], arrays: list[dict]) -> tuple[list[str], list[str]]:
    """C struct lines, and the member names with their offsets for asserts."""
    # Group array registers: (array name, index) -> {member: Register}.
    members: list[tuple[int, str, object]] = []  # (offset, kind, payload)
    grouped: dict[str, dict[int, dict[str, Register]]] = {}
    for reg in regs:
        for a in arrays:
            m = re.fullmatch(a["pattern"], reg.name)
            if m:
                member = a["member"].format(**m.groupdict())
                grouped.setdefault(a["name"], {}).setdefault(int(m.group("i")), {})[member] = reg
                break
        else:
            members.append((reg.offset, "reg", reg))
    for a in arrays:
        elems = grouped.get(a["name"])
        if not elems:
            continue
        idx = sorted(elems)
        if idx != list(range(len(idx))):
            raise SystemExit(f"svd2c: {tname}.{a['name']}: indices {idx} not 0..n-1")
        first = elems[0]
        start = min(r.offset for r in first.values())
        layout = sorted((r.offset - start, name, r.size) for name, r in first.items())
        stride = (min(r.offset for r in elems[1].values()) - start) if len(idx) > 1 else None
        for i in idx:
            e = elems[i]
            s = min(r.offset for r in e.values())
            if sorted((r.offset - s, name, r.size) for name, r in e.items()) != layout:
                raise SystemExit(f"svd2c: {tname}.{a['name']}[{i}]: layout differs from [0]")
            if stride is not None and s != start + i * stride:
                raise SystemExit(f"svd2c: {tname}.{a['name']}[{i}]: stride is not constant")
        members.append((start, "array", (a, layout, len(idx), stride, first)))
    members.sort(key=lambda m: m[0])

    lines = ["typedef struct {"]
    checks = []
    at = 0
    n_res = 0

    def pad(to: int) -> None:
        nonlocal at, n_res
        if to < at:
            raise SystemExit(f"svd2c: {tname}: registers overlap at 0x{to:03X}")
        if to > at:
            gap = to - at
            if gap % 4 == 0 and at % 4 == 0:
                lines.append(f"    uint32_t RESERVED{n_res}[{gap // 4}]; /* 0x{at:03X} */")
            else:
                lines.append(f"    uint8_t RESERVED{n_res}[{gap}]; /* 0x{at:03X} */")
            n_res += 1
            at = to

    for off, kind, payload in members:
        pad(off)
        if kind == "reg":
            reg = payload
            lines.append(f"    volatile {CTYPE[reg.size]} {reg.name}; /* 0x{off:03X} {reg.desc} */")
            checks.append((reg.name, off))
            at = off + reg.size // 8
        else:
            a, layout, n, stride, first = payload
            sub = ["    struct {"]
            sat = 0
            for rel, name, size in layout:
                if rel > sat:
                    sub.append(f"        uint8_t RESERVED{n_res}[{rel - sat}];")
                    n_res += 1
                sub.append(f"        volatile {CTYPE[size]} {name};")
                sat = rel + size // 8
            if stride is not None and stride > sat:
                sub.append(f"        uint8_t RESERVED{n_res}[{stride - sat}];")
                n_res += 1
                sat = stride
            sub.append(f"    }} {a['name']}[{n}]; /* 0x{off:03X} */")
            lines += sub
            checks.append((f"{a['name']}[0]", off))
            at = off + sat * n
    lines.append(f"}} {tname}_TypeDef;")
    return lines, checks


def generate(cfg: dict, svd: Svd) -> tuple[str, str]:
    periphs: dict[str, dict] = cfg["peripherals"]
    for pname in periphs:
        if pname not in svd.periph:
            raise SystemExit(f"svd2c: peripheral {pname} is not in {cfg['svd']}")
    irqs = svd.interrupts(set(periphs))
    n_irq = max(irqs) + 1

    h = [
        f"/* Generated by tools/svd/svd2c.py from {cfg['svd']} ({svd.name}, SVD version "
        f"{svd.version}),",
        f" * configuration {cfg['config_name']}. Do not edit: change the configuration or the",
        " * generator. The SVD is ST's (deps/svd/License.html). */",
        "#ifndef STM32_REGS_H",
        "#define STM32_REGS_H",
        "",
        "#include <stddef.h>",
        "#include <stdint.h>",
        "",
        f'#define STM32_SVD_DEVICE "{svd.name}"',
        f"#define STM32_IRQ_COUNT {n_irq}u",
        "",
        "/* Interrupt numbers (exception number = IRQ number + 16). */",
        "typedef enum {",
    ]
    h += [f"    {name}_IRQn = {num}," for num, name in irqs.items()]
    h += [
        "} stm32_irqn_t;",
        "",
        "/* Handlers: define one to override its weak alias of Default_Handler. */",
    ]
    h += [f"void {name}(void);" for name in SYSTEM_HANDLERS if name]
    h += [f"void {name}_IRQHandler(void);" for name in irqs.values()]
    h.append("")

    # Types: union of the registers of every peripheral mapped to each type.
    types: dict[str, list[str]] = {}
    for pname, pc in periphs.items():
        types.setdefault(pc.get("type", pname), []).append(pname)
    for tname, pnames in types.items():
        by_off: dict[int, Register] = {}
        fields_of: dict[str, list[Field]] = {}
        tcfg = cfg.get("types", {}).get(tname, {})
        for pname in pnames:
            pc = periphs[pname]
            for reg in svd.registers(pname, pc.get("strip_prefix", []), tcfg.get("rename", {})):
                old = by_off.get(reg.offset)
                if old is not None and old.name != reg.name:
                    raise SystemExit(
                        f"svd2c: {tname}: offset 0x{reg.offset:X} is {old.name} and {reg.name}"
                    )
                if old is None:
                    by_off[reg.offset] = reg
                fields_of.setdefault(reg.name, [])
                known = {f.name for f in fields_of[reg.name]}
                fields_of[reg.name] += [f for f in reg.fields if f.name not in known]
        regs = [by_off[o] for o in sorted(by_off)]
        # Fields the SVD lacks or splits (ST's older SVDs list PLLM as PLLM0..5,
        # and miss PWR_CR.VOS): added from the reference manual, with the
        # section cited; an addition that the SVD already has is an error, so
        # a fixed SVD is noticed.
        for rname, extra in tcfg.get("add_fields", {}).items():
            if rname not in fields_of:
                raise SystemExit(f"svd2c: {tname}: add_fields: no register {rname}")
            for name, pos, width, cite in extra:
                if any(f.name == name for f in fields_of[rname]):
                    raise SystemExit(f"svd2c: {tname}.{rname}.{name} is in the SVD already")
                fields_of[rname].append(Field(name, pos, width, f"not in the SVD: {cite}"))
        arrays = tcfg.get("arrays", [])
        lines, checks = _struct(tname, regs, arrays)
        h.append(f"/* {tname}: {', '.join(pnames)} */")
        h += lines
        h += [
            f'_Static_assert(offsetof({tname}_TypeDef, {m}) == 0x{o:X}u, "{tname}.{m}");'
            for m, o in checks
        ]
        for pname in pnames:
            inst = periphs[pname].get("instance", pname)
            base = svd.base_address(pname)
            h.append(f"#define {inst}_BASE 0x{base:08X}u")
            h.append(f"#define {inst} (({tname}_TypeDef *){inst}_BASE)")
        # Field macros: plain registers by name; array members by member name.
        no_fields = set(tcfg.get("no_fields", []))
        emitted: set[str] = set()
        for reg in regs:
            member = reg.name
            for a in arrays:
                m = re.fullmatch(a["pattern"], reg.name)
                if m:
                    if int(m.group("i")) != 0:
                        member = None
                    else:
                        member = a["member"].format(**m.groupdict())
                    break
            if member is None or member in no_fields or member in emitted:
                continue
            emitted.add(member)
            for f in fields_of.get(reg.name, []):
                macro = f"{tname}_{member}_{f.name}"
                mask = (1 << f.width) - 1
                if f.desc.startswith("not in the SVD"):
                    h.append(f"/* {f.desc} */")
                h.append(f"#define {macro}_Pos {f.pos}u")
                h.append(f"#define {macro}_Msk (0x{mask:X}u << {macro}_Pos)")
        h.append("")
    h += ["#endif /* STM32_REGS_H */", ""]

    c = [
        f"/* Generated by tools/svd/svd2c.py from {cfg['svd']} ({svd.name}); do not edit.",
        " * The vector table: initial stack pointer, ARMv7-M system exceptions",
        " * (ARMv7-M ARM B1.5.2), then the device's IRQs. Every handler is a weak alias",
        " * of Default_Handler, which calls stm32_unhandled() (hal/stm32/startup.c),",
        " * until a port defines it. */",
        '#include "stm32_regs.h"',
        '#include "startup.h"',
        "",
    ]
    system = SYSTEM_HANDLERS
    c += [
        "/* Here, not in startup.c: an alias must name a function of its own unit. */",
        "void Default_Handler(void) { stm32_unhandled(); }",
        "",
    ]
    for name in [s for s in system if s] + [f"{n}_IRQHandler" for n in irqs.values()]:
        c.append(f'void {name}(void) __attribute__((weak, alias("Default_Handler")));')
    c += [
        "",
        '__attribute__((section(".isr_vector"), used))',
        "const stm32_vector_table_t stm32_vectors = {",
        "    .initial_sp = &__stack_top,",
        "    .system = {",
        "        Reset_Handler,",
    ]
    c += [f"        {s if s else '0'}," for s in system]
    c += ["    },", "    .irq = {"]
    for num in range(n_irq):
        c.append(
            f"        [{num}] = {irqs[num]}_IRQHandler," if num in irqs else f"        [{num}] = 0,"
        )
    c += ["    },", "};", ""]
    return "\n".join(h), "\n".join(c)


def main(argv: list[str]) -> int:
    if len(argv) != 4:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    cfg_path, svd_dir, out_dir = Path(argv[1]), Path(argv[2]), Path(argv[3])
    cfg = json.loads(cfg_path.read_text())
    cfg["config_name"] = cfg_path.as_posix()
    svd = Svd(svd_dir / cfg["svd"])
    header, vectors = generate(cfg, svd)
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, text in (("stm32_regs.h", header), ("stm32_vectors.c", vectors)):
        (out_dir / name).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
