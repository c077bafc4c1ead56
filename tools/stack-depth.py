#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Worst-case stack depth of a function from GCC's call-graph files.

    stack-depth.py [--indirect NAME,NAME...] ROOT FILE.ci...

Compile with -fcallgraph-info=su: each object gets a .ci file (VCG) whose
nodes carry the frame size of a function ("N bytes (static)") and whose
edges are its calls. The depth of ROOT is its frame plus the deepest of its
callees, through every path. Calls through a function pointer go to
"__indirect_call"; --indirect names the functions they can reach (for the IK
core: the kinematics backend's eval and eval_tol). Functions without a
frame in the files (libgcc's helpers) count as 0 and are listed. A frame
marked "dynamic" or a cycle makes the bound unknown: the script says so and
exits 1.
"""
import re
import sys


def parse(paths):
    frames, edges, dynamic = {}, {}, set()
    node = re.compile(r'node: \{ title: "([^"]+)" label: "([^"]*)"')
    edge = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')
    for path in paths:
        with open(path) as f:
            for line in f:
                m = node.match(line)
                if m:
                    title, label = m.groups()
                    s = re.search(r'(\d+) bytes \((static|dynamic[^)]*)\)', label)
                    if s:
                        frames[title] = int(s.group(1))
                        if s.group(2) != 'static':
                            dynamic.add(title)
                    continue
                m = edge.match(line)
                if m:
                    edges.setdefault(m.group(1), set()).add(m.group(2))
    return frames, edges, dynamic


def main():
    args = sys.argv[1:]
    indirect = []
    if len(args) >= 2 and args[0] == '--indirect':
        indirect = [n for n in args[1].split(',') if n]
        args = args[2:]
    if len(args) < 2:
        sys.exit(__doc__)
    root, files = args[0], args[1:]
    frames, edges, dynamic = parse(files)

    # a call to a global function names it plainly; its definition is "file:name"
    by_name = {}
    for title in frames:
        by_name.setdefault(title.split(':')[-1], []).append(title)

    def resolve(t):
        if t == '__indirect_call':
            return [r for n in indirect for r in by_name.get(n, [n])]
        if t in frames:
            return [t]
        return by_name.get(t, [t])

    unknown, memo, active = set(), {}, set()

    def depth(t):
        if t in memo:
            return memo[t]
        if t in active:
            sys.exit('stack-depth: recursion through %s: no bound' % t)
        active.add(t)
        best, path = 0, []
        for callee in edges.get(t, ()):
            for c in resolve(callee):
                d, p = depth(c)
                if d > best:
                    best, path = d, p
        active.discard(t)
        if t not in frames:
            unknown.add(t.split(':')[-1])
        memo[t] = (frames.get(t, 0) + best, [t] + path)
        return memo[t]

    roots = resolve(root)
    total, path = max(depth(r) for r in roots)
    print('%s: %d bytes at most' % (root, total))
    print('  deepest path: ' + ' > '.join('%s (%d)' % (p.split(':')[-1], frames.get(p, 0)) for p in path))
    if unknown:
        print('  no frame known (counted as 0): ' + ' '.join(sorted(unknown)))
    bad = [p for p in path if p in dynamic]
    if bad:
        print('  dynamic frames on the path: ' + ' '.join(bad))
        sys.exit(1)


if __name__ == '__main__':
    main()
