#!/usr/bin/env python3
"""How a function's instructions split into a fixed cost per call and the work of its loops.

Reads a callgrind profile taken with `--dump-instr=yes` and counts, for every function whose
name contains the given text (a closest-hit query `closest_avx2`, a shadow query
`blocked_avx2`, ...), how often each of its instructions ran. The instructions that ran once
per call are the function's fixed cost (prologue, setup, epilogue); those that ran k·calls
times for other k are its loops (a node test runs once per node visited, a packet test once
per packet). It prints the calls, the instructions per call, the fixed cost and the largest
groups of instructions that ran equally often (docs/dev/performance-log.md, 2026-12-06).

    valgrind --tool=callgrind --dump-instr=yes --callgrind-out-file=cg.out \
        target/release/tessera render cornell-box --width 48 --height 48 --spp 16 --threads 1
    python3 docs/tools/per_call.py cg.out closest_avx2 blocked_avx2

Callgrind sees no AVX-512 (it hides the feature), so the walk it counts is the AVX2 copy.
"""
import argparse
import collections
import re

POSITION = re.compile(r'^(0x[0-9a-f]+|[+-]\d+|\*)\s+(?:[+-]?\d+|\*)(?:\s+(\d+))?')
NAME = re.compile(r'^(fn|cfn)=\((\d+)\)(?: (.*))?')


def instruction_counts(path, wanted):
    """{function name: {address: times executed}} for the functions whose name contains `wanted`."""
    names, counts = {}, collections.defaultdict(collections.Counter)
    current, address, call_cost_follows = None, 0, False
    for line in open(path):
        named = NAME.match(line)
        if named:
            if named.group(3):
                names[named.group(2)] = named.group(3)
            if named.group(1) == 'fn':
                current = names.get(named.group(2))
            continue
        if line.startswith('calls='):
            # The next cost line is the callee's inclusive cost, charged to the call instruction.
            call_cost_follows = True
            continue
        pos = POSITION.match(line)
        if not pos:
            continue
        token = pos.group(1)
        address = int(token, 16) if token.startswith('0x') else address if token == '*' else address + int(token)
        if call_cost_follows:
            call_cost_follows = False
            continue
        if current and wanted in current and pos.group(2):
            counts[current][address] += int(pos.group(2))
    return counts


def report(name, by_address):
    # The entry instruction runs once per call: the lowest address of the function's body.
    calls = by_address[min(by_address)]
    total = sum(by_address.values())
    groups = collections.Counter()
    for times in by_address.values():
        groups[times] += 1
    print(f'{name}')
    print(f'  {calls:,} calls, {total:,} instructions: {total / calls:.0f} per call')
    print(f'  run once per call (fixed cost): {groups[calls]} instructions')
    print('  instructions that ran equally often (largest groups): instructions × times per call')
    for times, n in sorted(groups.items(), key=lambda kv: -kv[1] * kv[0])[:6]:
        print(f'    {n:4d} × {times / calls:.3f}')


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('profile')
    parser.add_argument('functions', nargs='+', help='text the function names contain')
    args = parser.parse_args()
    for wanted in args.functions:
        counts = instruction_counts(args.profile, wanted)
        if not counts:
            print(f'{wanted}: no function of that name ran')
        for name, by_address in counts.items():
            report(name, by_address)


if __name__ == '__main__':
    main()
