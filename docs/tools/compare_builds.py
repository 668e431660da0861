#!/usr/bin/env python3
"""Two builds of `tessera` side by side: instructions, CPU time and pixels, scene by scene.

The plain release build's speed moves with the inliner's choices, and code far from the render
loop can move those (docs/dev/performance-log.md, 2026-12-06: a 4 % loss, found by building an older
commit beside the current one). This script does that comparison:

1. builds BASE (any commit) in a git worktree under target/compare/, and the working tree as
   it is (`cargo build --release`), unless binaries are given;
2. per scene, counts a small render's instructions with callgrind (repeatable on a noisy VM),
   when valgrind is installed;
3. per scene, renders on one thread with the two binaries alternated, ROUNDS times, and prints
   the minimum and median CPU seconds of each (minima resist a noisy VM best);
4. checks that both binaries give the same pixel digest: a change meant to keep the bits must.

    python3 docs/tools/compare_builds.py --base 9de99ef
    python3 docs/tools/compare_builds.py --base HEAD~1 --scenes cornell-box --rounds 20
    python3 docs/tools/compare_builds.py --base-bin /tmp/old/tessera --new-bin target/release/tessera

Ratios are new ÷ base: below 1, the working tree's build does less or is faster. The base's
worktree and build stay under target/compare/ for the next run; `rm -rf target/compare && git
worktree prune` removes them.
"""
import argparse
import os
import pathlib
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

DIGEST = re.compile(r'pixels sha256: ([0-9a-f]{64})')
COLLECTED = re.compile(r'Collected : (\d+)')
# The counted render: small, since callgrind runs it some fifty times slower.
COUNTED_SIZE, COUNTED_SPP = 48, 16


def repo_root():
    out = subprocess.run(['git', 'rev-parse', '--show-toplevel'], capture_output=True, text=True, check=True)
    return pathlib.Path(out.stdout.strip())


def build(source, target_dir=None):
    """`tessera` built in release from `source`; its path."""
    env = dict(os.environ)
    if target_dir:
        env['CARGO_TARGET_DIR'] = str(target_dir)
    cmd = ['cargo', 'build', '--release', '-p', 'tessera-server', '--bin', 'tessera']
    print(f'building {source} ...', file=sys.stderr)
    subprocess.run(cmd, cwd=source, env=env, check=True, stdout=subprocess.DEVNULL)
    return pathlib.Path(target_dir or source / 'target') / 'release' / 'tessera'


def base_binary(root, rev):
    """`tessera` built from commit `rev` in a worktree of its own (reused if present)."""
    sha = subprocess.run(['git', 'rev-parse', '--verify', f'{rev}^{{commit}}'], cwd=root, capture_output=True,
                         text=True, check=True).stdout.strip()
    tree = root / 'target' / 'compare' / f'src-{sha[:12]}'
    if not tree.exists():
        # A worktree deleted with target/ (cargo clean) is still registered until pruned.
        subprocess.run(['git', 'worktree', 'prune'], cwd=root, check=True)
        subprocess.run(['git', 'worktree', 'add', '--detach', str(tree), sha], cwd=root, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    # A target directory shared by every base, so a second base rebuilds only what differs.
    return build(tree, root / 'target' / 'compare' / 'target'), sha[:12]


def render_args(scene, size, spp, out):
    return ['render', scene, '--width', str(size), '--height', str(size), '--spp', str(spp), '--threads', '1',
            '-o', out]


def digest_of(text):
    m = DIGEST.search(text)
    return m.group(1) if m else None


def instructions(binary, scene, out):
    """Instructions of the counted render by callgrind (the whole process), and its digest."""
    with tempfile.TemporaryDirectory() as tmp:
        run = subprocess.run(['valgrind', '--tool=callgrind', f'--callgrind-out-file={tmp}/cg.out', str(binary),
                              *render_args(scene, COUNTED_SIZE, COUNTED_SPP, out)], capture_output=True, text=True,
                             env=dict(os.environ, RUST_BACKTRACE='0'))
    if run.returncode != 0:
        sys.exit(f'{binary} failed on {scene} under callgrind:\n{run.stderr}')
    m = COLLECTED.search(run.stderr)
    return (int(m.group(1)) if m else None), digest_of(run.stdout + run.stderr)


def cpu_seconds(binary, scene, size, spp, out):
    """CPU seconds (user + system) of one render, and its digest."""
    before = os.times()
    run = subprocess.run([str(binary), *render_args(scene, size, spp, out)], capture_output=True, text=True,
                         env=dict(os.environ, RUST_BACKTRACE='0'))
    after = os.times()
    if run.returncode != 0:
        sys.exit(f'{binary} failed on {scene}:\n{run.stderr}')
    spent = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    return spent, digest_of(run.stdout + run.stderr)


def compare_scene(scene, binaries, args, out):
    """Prints one scene's rows; returns whether the two builds' digests agreed."""
    print(scene)
    # Per render (size, spp), the digests each build gave: the builds must agree on each.
    digests = {}
    if args.callgrind:
        counts = {}
        for name, binary in binaries.items():
            counts[name], d = instructions(binary, scene, out)
            digests.setdefault((COUNTED_SIZE, COUNTED_SPP), {}).setdefault(name, set()).add(d)
        if None in counts.values():
            print('  instructions: callgrind printed no count')
        else:
            ratio = counts['new'] / counts['base']
            print(f'  instructions ({COUNTED_SIZE}×{COUNTED_SIZE}, {COUNTED_SPP} spp): base {counts["base"] / 1e6:.1f} M, new {counts["new"] / 1e6:.1f} M, '
                  f'new ÷ base {ratio:.4f}')
    times = {name: [] for name in binaries}
    for _ in range(args.rounds):
        for name, binary in binaries.items():
            t, d = cpu_seconds(binary, scene, args.size, args.spp, out)
            times[name].append(t)
            digests.setdefault((args.size, args.spp), {}).setdefault(name, set()).add(d)
    figures = {name: (min(v), statistics.median(v)) for name, v in times.items()}
    for name, (low, mid) in figures.items():
        print(f'  CPU s ({args.size}×{args.size}, {args.spp} spp, {args.rounds} rounds): {name:4s} min {low:.3f}, median {mid:.3f}')
    (bmin, bmed), (nmin, nmed) = figures['base'], figures['new']
    print(f'  new ÷ base: minima {nmin / bmin:.3f}, medians {nmed / bmed:.3f}')
    same = True
    for (size, spp), by_build in sorted(digests.items()):
        seen = by_build['base'] | by_build['new']
        agree = len(seen) == 1 and None not in seen
        same &= agree
        shown = ', '.join(sorted(d[:12] if d else 'none' for d in seen))
        print(f'  pixels at {size}×{size}, {spp} spp: {"the same digest" if agree else "DIFFERENT digests"} ({shown})')
    return same


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--base', help='commit to compare against (built in target/compare/)')
    parser.add_argument('--base-bin', help='a base binary instead of --base')
    parser.add_argument('--new-bin', help="a new binary instead of building the working tree")
    parser.add_argument('--scenes', default='cornell-box,glossy,textured', help='bundled scenes, comma-separated')
    parser.add_argument('--rounds', type=int, default=6, help='alternated renders per binary and scene')
    parser.add_argument('--size', type=int, default=128, help='image width and height of the timed renders')
    parser.add_argument('--spp', type=int, default=64, help='samples per pixel of the timed renders')
    parser.add_argument('--no-callgrind', dest='callgrind', action='store_false', help='skip the instruction counts')
    args = parser.parse_args()
    if bool(args.base) == bool(args.base_bin):
        parser.error('give one of --base and --base-bin')
    if args.callgrind and not shutil.which('valgrind'):
        print('valgrind not found: instruction counts skipped (apt-get install valgrind)', file=sys.stderr)
        args.callgrind = False
    root = repo_root()
    base, label = (pathlib.Path(args.base_bin), args.base_bin) if args.base_bin else base_binary(root, args.base)
    new = pathlib.Path(args.new_bin) if args.new_bin else build(root)
    binaries = {'base': base, 'new': new}
    print(f'base: {label} ({base})\nnew:  {new}')
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, 'compare.exr')
        agreed = [compare_scene(scene, binaries, args, out) for scene in args.scenes.split(',')]
    if not all(agreed):
        print('the two builds render different images')


if __name__ == '__main__':
    main()
