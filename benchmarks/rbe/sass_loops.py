#!/usr/bin/env python3
"""Instruction mix of each loop of a CUDA kernel, read from an sm_90 cubin without cuobjdump.

Counts what a change does to the instructions per FMA before any device time is spent
(docs/rbe.md, "How cuda-resident reaches its figures"). On sm_70 and later every SASS
instruction is 16 bytes; the low 9 bits of its first 64-bit word name the operation, and a
backward branch closes a loop. The names below were identified by compiling kernels of known
content (a chain of fmaf is FFMA, a shared load loop is LDS, ...); other operations print as
hex. It is a counting aid, not a disassembler: for the real thing use cuobjdump --dump-sass.

  nvcc -O3 -arch=sm_90 -cubin -o k.cubin k.cu [the project's flags: -I. -std=c++20 ...]
  sass_loops.py k.cubin rbe_resident_fused     # every kernel whose name contains the text
"""
import argparse
import collections
import struct

NAMES = {
    0x002: "MOV", 0x005: "CS2R", 0x007: "SEL", 0x00B: "FSETP", 0x00C: "ISETP", 0x010: "IADD3",
    0x011: "LEA", 0x012: "LOP3", 0x019: "SHF", 0x01C: "PLOP3", 0x020: "FMUL", 0x021: "FADD",
    0x023: "FFMA", 0x024: "IMAD", 0x025: "IMAD.WIDE", 0x028: "DMUL", 0x029: "DADD", 0x02B: "DFMA",
    0x108: "MUFU", 0x118: "NOP", 0x119: "S2R", 0x11D: "BAR", 0x147: "BRA", 0x14D: "EXIT",
    0x181: "LDG", 0x182: "LDC", 0x184: "LDS", 0x186: "STG", 0x188: "STS", 0x189: "SHFL",
    0x1AE: "LDGSTS", 0x1AF: "LDGDEPBAR",
}


def text_sections(path):
    """The .text.<kernel> sections of an ELF64 cubin: {name: bytes}."""
    data = open(path, "rb").read()
    if data[:4] != b"\x7fELF" or data[4] != 2:
        raise SystemExit(f"{path}: not an ELF64 file (a cubin: nvcc -cubin)")
    shoff, = struct.unpack_from("<Q", data, 0x28)
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", data, 0x3A)
    sections = []
    for i in range(shnum):
        name, _, _, _, off, size = struct.unpack_from("<IIQQQQ", data, shoff + i * shentsize)
        sections.append((name, off, size))
    strtab = sections[shstrndx][1]
    out = {}
    for name, off, size in sections:
        end = data.index(b"\0", strtab + name)
        n = data[strtab + name:end].decode()
        if n.startswith(".text."):
            out[n[len(".text."):]] = data[off:off + size]
    return out


def branch_target(pc, lo, hi):
    """Target of a BRA at byte offset pc: a signed word offset from the next instruction."""
    field = ((lo >> 16) & 0xFF) | ((lo >> 34) << 8) | ((hi & 0x3FFFF) << 38)
    if field & (1 << 55):
        field -= 1 << 56
    return pc + 16 + 4 * field


def instructions(code):
    for pc in range(0, len(code), 16):
        lo, hi = struct.unpack_from("<QQ", code, pc)
        yield pc, lo & 0x1FF, lo, hi


def mix(ops):
    counts = collections.Counter(NAMES.get(op, f"0x{op:03x}") for op in ops)
    return " ".join(f"{k}:{v}" for k, v in counts.most_common(14))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cubin")
    ap.add_argument("kernel", nargs="?", default="", help="text in the (mangled) kernel name")
    a = ap.parse_args()
    for name, code in text_sections(a.cubin).items():
        if a.kernel not in name:
            continue
        ins = list(instructions(code))
        print(f"{name}: {len(ins)} instructions; {mix(op for _, op, _, _ in ins)}")
        for pc, op, lo, hi in ins:
            if op != 0x147:
                continue
            target = branch_target(pc, lo, hi)
            if target <= pc:  # a backward branch closes a loop [target, pc]
                body = [o for p, o, _, _ in ins if target <= p <= pc]
                print(f"  loop {target:#06x}-{pc:#06x}: {len(body)} instructions; {mix(body)}")


if __name__ == "__main__":
    main()
