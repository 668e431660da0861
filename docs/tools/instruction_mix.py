#!/usr/bin/env python3
"""What kinds of instructions a render executes, split into tracing and shading.

Reads a callgrind profile taken with `--dump-instr=yes` and the binary it profiled, classifies
every executed x86-64 instruction by mnemonic (scalar or packed float arithmetic, moves, integer
work, branches, ...) and prints the counts for BVH traversal (`Accel`'s `intersect_where`,
`occluded_where`, `closest`, `blocked` and their AVX2 copies) and for the rest of the tracer
(shading and sampling). It answers "what would running several paths in SIMD lanes shrink?"
(docs/dev/performance-log.md, 2026-12-03).

    valgrind --tool=callgrind --dump-instr=yes --callgrind-out-file=cg.out \
        target/release/tessera render cornell-box --width 48 --height 48 --spp 16 --threads 1
    python3 docs/tools/instruction_mix.py cg.out target/release/tessera [--lines N]

`--lines N` also lists the N source lines of shading with the most instructions.
"""
import argparse
import collections
import os
import re
import subprocess

CLASSES = [
    ('fp scalar arith', r'^v?(add|sub|mul|div|sqrt|min|max|rcp|rsqrt)(ss|sd)$'),
    ('fp packed arith', r'^v?(add|sub|mul|div|sqrt|min|max|rcp|rsqrt|hadd)(ps|pd)$'),
    ('fp compare', r'^(v?cmp\w*(ss|sd|ps|pd)|v?u?comis[sd])$'),
    ('fp logic/mask', r'^v?(and|andn|or|xor)(ps|pd)$'),
    ('convert', r'^v?cvt\w+$'),
    ('shuffle', r'^v?(shufps|unpck\w+|movlhps|movhlps|insertps|pshufd|blend\w*|movsldup|movshdup|'
                r'punpck\w+|pextr\w|pinsr\w|palignr|psrldq|pslldq|perm\w+|broadcast\w+|pbroadcast\w)$'),
    ('vector move/load/store', r'^v?(movss|movsd|movaps|movups|movapd|movupd|movd|movq|movdqa|movdqu|'
                               r'movlps|movhps|movlpd|movhpd)$'),
    ('vector int', r'^v?p\w+$'),
    ('branch', r'^j\w+$'),
    ('call/stack', r'^(call|ret|push|pop)\w*$'),
    ('int move/lea', r'^(mov|lea)\w*$'),
    ('setcc/cmov', r'^(set|cmov)\w+$'),
]


TRACE_FUNCTIONS = ('intersect_where', 'occluded_where', '>::closest', '>::blocked')


def classify(mnemonic):
    if mnemonic is None:
        return 'unknown'
    for name, pattern in CLASSES:
        if re.match(pattern, mnemonic):
            return name
    return 'int alu/other'


def group(function):
    # The walk is `Accel::closest`/`blocked`, or their AVX2 copies `closest_avx2`/`blocked_avx2`
    # (measured 2026-12-05), inlined into `intersect_where`/`occluded_where` or called from them.
    if function and 'tracer::accel' in function and any(name in function for name in TRACE_FUNCTIONS):
        return 'trace'
    if function and ('tessera_worker::tracer' in function or 'sincos' in function or 'sinf' in function):
        return 'shade+sample'
    return 'other'


def parse_callgrind(path):
    """Self cost per instruction address of the profiled binary, with function and source line.

    Positions are `instr line`; '+n', '-n' and '*' are relative to the previous cost line
    (decimal), and a `calls=` line's target does not move them. The cost line after `calls=`
    is the call's inclusive cost and is skipped."""
    names, cost, where = {}, collections.Counter(), {}
    function, source, obj = None, '?', None
    last_addr = last_line = 0
    skip_next = False

    def named(kind, text):
        m = re.match(r'\((\d+)\)(?: (.*))?', text)
        if m.group(2):
            names[(kind, m.group(1))] = m.group(2)
        return names.get((kind, m.group(1)), '?')

    for raw in open(path):
        line = raw.rstrip('\n')
        if not line:
            continue
        key = line.split('=', 1)[0] if re.match(r'^[a-z]+=', line) else None
        if key in ('fn', 'cfn'):
            value = named('fn', line[len(key) + 1:])
            function = value if key == 'fn' else function
            continue
        if key in ('fl', 'fi', 'fe', 'cfi', 'cfl'):
            value = named('fl', line[len(key) + 1:])
            source = value if key in ('fl', 'fi', 'fe') else source
            continue
        if key in ('ob', 'cob'):
            value = named('ob', line[len(key) + 1:])
            obj = value if key == 'ob' else obj
            continue
        if key == 'calls':
            skip_next = True
            continue
        if key is not None or re.match(r'^[a-z]+:', line):
            continue
        fields = line.split()
        a = fields[0]
        if a.startswith('0x'):
            addr = int(a, 16)
        elif a[0] in '+-':
            addr = last_addr + int(a)
        elif a == '*':
            addr = last_addr
        else:
            continue
        last_addr = addr
        if len(fields) >= 3:
            b = fields[1]
            last_line = last_line if b == '*' else last_line + int(b) if b[0] in '+-' else int(b)
        if skip_next:
            skip_next = False
            continue
        if 'tessera' not in (obj or ''):
            continue
        cost[addr] += int(fields[-1])
        where[addr] = (function, os.path.basename(source), last_line)
    return cost, where


def mnemonics(binary):
    out = subprocess.run(['objdump', '-d', '--no-show-raw-insn', binary], capture_output=True, text=True, check=True).stdout
    found = {}
    for line in out.splitlines():
        m = re.match(r'^\s*([0-9a-f]+):\s+(\S+)', line)
        if m:
            found[int(m.group(1), 16)] = m.group(2)
    return found


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('callgrind_out')
    ap.add_argument('binary')
    ap.add_argument('--lines', type=int, default=0)
    args = ap.parse_args()
    cost, where = parse_callgrind(args.callgrind_out)
    ops = mnemonics(args.binary)
    mix = collections.defaultdict(collections.Counter)
    by_line = collections.defaultdict(collections.Counter)
    for addr, c in cost.items():
        function, source, line = where[addr]
        g, kind = group(function), classify(ops.get(addr))
        mix[g][kind] += c
        if g == 'shade+sample':
            by_line[(source, line)][kind] += c
    total = sum(sum(c.values()) for c in mix.values())
    print(f'{total / 1e6:.1f} M instructions in the binary')
    for g in ('trace', 'shade+sample', 'other'):
        counts = mix[g]
        n = sum(counts.values())
        print(f'\n{g}: {n / 1e6:.1f} M ({100 * n / total:.1f} %)')
        for kind, c in counts.most_common():
            print(f'  {kind:24s} {c / 1e6:8.2f} M {100 * c / n:5.1f} %')
    if args.lines:
        print(f'\nshade+sample: the {args.lines} source lines with most instructions (M; moves = vector + int moves)')
        rows = sorted(by_line.items(), key=lambda kv: -sum(kv[1].values()))[:args.lines]
        for (source, line), counts in rows:
            moves = counts['vector move/load/store'] + counts['int move/lea']
            fp = counts['fp scalar arith'] + counts['fp packed arith']
            print(f'  {source}:{line:<6} {sum(counts.values()) / 1e6:6.2f}  moves {moves / 1e6:5.2f}  fp {fp / 1e6:5.2f}  int {counts["int alu/other"] / 1e6:5.2f}')


if __name__ == '__main__':
    main()
