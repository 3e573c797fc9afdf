#!/usr/bin/env python3
"""The dynamic instruction mix of the estimator: executions per pixel sample of each
mnemonic and of each kind of instruction (moves, float arithmetic, masks, branches, ...),
counted by callgrind inside `Tracer::run` in the stokes binary only (Embree excluded).

    valgrind --tool=callgrind --dump-instr=yes --compress-pos=no --compress-strings=no \\
        --toggle-collect='*Tracer*run*' --callgrind-out-file=cg.out \\
        target/release/stokes render scenes/cornell-box.toml --res 64x64 --spp 16 \\
        --threads 1 --rays packet -o x.exr
    python3 benches/opmix.py target/release/stokes cg.out 65536 [--mnemonics]

65536 = 64 × 64 × 16 pixel samples. Mnemonics come from `objdump -d` of the same binary.
"""
import collections
import re
import subprocess
import sys

from bysource import costs

KINDS = [
    ("moves and shuffles", r"(mov\w*|unpck\w+|punpck\w+|shufps|pshufd|movlhps|movhlps)"),
    ("float arithmetic", r"(add|sub|mul|div|min|max|sqrt)(ss|ps|sd|pd)"),
    (
        "float compares, masks, selects",
        r"(cmp\w*(ps|ss)|andn?ps|orps|xorps|andpd|orpd|xorpd|movmskps|ucomiss|comiss"
        r"|pandn?|por|pxor|pcmp\w+|psrld|pslld|psrad|paddd|psubd|pmuludq)",
    ),
    ("conversions", r"cvt\w+"),
    ("branches", r"j\w+"),
    (
        "integer and addressing",
        r"(lea|add|sub|i?mul|shr|shl|sar|and|or|xor|cmp[bwlq]?|test[bwlq]?|inc|dec|ror|rol"
        r"|neg|not|sbb|adc|cmov\w+|set\w+|tzcnt|popcnt|movabs|bt|bsf|bsr|xchg|lock)",
    ),
    ("calls and stack", r"(call|ret|push|pop)"),
]


def mnemonics(binary):
    dis = subprocess.run(
        ["objdump", "-d", "--no-show-raw-insn", binary], capture_output=True, text=True
    ).stdout
    out = {}
    for line in dis.splitlines():
        m = re.match(r"\s*([0-9a-f]+):\s+(\S+)", line)
        if m:
            out[int(m.group(1), 16)] = m.group(2)
    return out


def main():
    binary, out, samples = sys.argv[1], sys.argv[2], float(sys.argv[3])
    names = mnemonics(binary)
    per = costs(binary, out, "Ir")
    unknown = sum(c for a, c in per.items() if a not in names)
    if unknown > 0.01 * sum(per.values()):
        sys.exit(f"{out} does not match {binary}: record it with this binary")
    by_mnemonic = collections.Counter()
    for a, c in per.items():
        by_mnemonic[names.get(a, "?")] += c
    by_kind = collections.Counter()
    for mn, c in by_mnemonic.items():
        kind = next((k for k, pat in KINDS if re.fullmatch(pat, mn)), "other")
        by_kind[kind] += c
    total = sum(by_mnemonic.values())
    print(f"total {total / samples:.0f} instructions per sample")
    for kind, _ in KINDS + [("other", None)]:
        print(f"{kind:32} {by_kind[kind] / samples:8.0f}")
    if "--mnemonics" in sys.argv:
        for mn, c in by_mnemonic.most_common():
            print(f"  {mn:12} {c / samples:8.1f}")


if __name__ == "__main__":
    main()
