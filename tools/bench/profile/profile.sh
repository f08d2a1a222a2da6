#!/bin/bash
# SPDX-License-Identifier: MIT
# Where a control step's instructions go, by function and by source line
# (docs/strategy.md, "Cost"). Run from the repository after
# `make build/bench/CONFIG.elf`:
#   tools/bench/profile/profile.sh CONFIG [LOAD [STRATEGY]] [OUT]
# CONFIG m4f-float or m3-fixed; LOAD 0..3 (load-1, load-4, load-8, load-48; default
# 2); STRATEGY 0 paper, 1 mstc (default). Builds prof_main.c against the
# bench's objects and the config's library, runs it under QEMU with
# -icount shift=0 -d in_asm,exec,nochain (a line per translation block run,
# its instructions when translated: a few hundred MB, deleted after), and
# counts each block's instructions between prof_begin and prof_end.
# Writes OUT (default /tmp/mstc-profile-CONFIG)/profile.txt (per function:
# out of line, then inlined) and prof.pkl for query.py (per source line).
set -euo pipefail
cfg=$1
load=${2:-2}
strat=${3:-1}
o=${4:-/tmp/mstc-profile-$cfg}
here=$(dirname "$0")
case $cfg in
m4f-float)
    cpu="-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard"
    mach=mps2-an386
    def=""
    ;;
m3-fixed)
    cpu="-mcpu=cortex-m3 -mthumb -mfloat-abi=soft"
    mach=mps2-an385
    def="-DNUM_FIXED -Ideps/libfixmath -DFIXMATH_NO_CACHE"
    ;;
*)
    echo "profile.sh: config m4f-float or m3-fixed" >&2
    exit 2
    ;;
esac
mkdir -p "$o"
# shellcheck disable=SC2086
arm-none-eabi-gcc $cpu -std=c11 -D_DEFAULT_SOURCE -O2 -g -ffunction-sections -fdata-sections \
    -Ifirmware -Ihal/include $def -Itools/bench -Ibuild/bench -Isim/dcmotor -DPROF_LOAD="$load" \
    -DPROF_STRATEGY="$strat" -c "$here/prof_main.c" -o "$o/prof_main.o"
# shellcheck disable=SC2086
arm-none-eabi-gcc $cpu "build/bench/$cfg/obj/tools/bench/startup.o" \
    "build/bench/$cfg/obj/tools/bench/bench_core.o" "$o/prof_main.o" "build/cross/$cfg/libmstc_fw.a" \
    --specs=rdimon.specs -T tools/bench/link.ld -Wl,--gc-sections -lm -o "$o/prof.elf"
timeout 600 qemu-system-arm -M "$mach" -nographic -monitor none -serial none \
    -semihosting-config enable=on,target=native -icount shift=0 -d in_asm,exec,nochain \
    -D "$o/log" -kernel "$o/prof.elf" >"$o/out.txt"
cat "$o/out.txt"
n=$(awk '/^checksum/{print $4}' "$o/out.txt")
python3 "$here/prof.py" "$o/prof.elf" "$o/log" "$n" "$o/prof.pkl" >"$o/profile.txt"
rm -f "$o/log"
cat "$o/profile.txt"
