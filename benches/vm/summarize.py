#!/usr/bin/env python3
"""Medians of run_all.sh's results (results/*-N.txt): one row per VM configuration."""
import collections, glob, os, re, statistics as st, sys

os.chdir(os.path.dirname(os.path.abspath(__file__)))
runs = collections.defaultdict(list)
for f in sorted(glob.glob((sys.argv[1] if len(sys.argv) > 1 else 'results') + '/*-[0-9].txt')):
    t = open(f).read()
    g = lambda pat: (lambda m: float(m.group(1)) if m else float('nan'))(re.search(pat, t))
    runs[os.path.basename(f)[:-6]].append(dict(
        us=g(r'us/decision ([\d.]+)'), api=g(r'inside the Rust API ([\d.]+)'), lua=g(r'; Lua ([\d.]+)\)'),
        checks=g(r'bound checks/decision ([\d.]+)'), noop=g(r'noop\(\) ([\d.]+) ns'),
        three=g(r'three\(\) \(3 numbers back\) ([\d.]+) ns'), fill=g(r'fill\(\) \(8 fields set from Rust\) ([\d.]+) ns'),
        loop=g(r"empty loop's ([\d.]+) ns"),
        checksum=(re.search(r'checksums (\w+)', t) or [None, '?'])[1],
        stopped=' '.join('stopped' if 'stopped after' in l and 'NOT' not in l else 'NOT' for l in t.splitlines() if l.startswith('bound,')),
        memory=(re.search(r'^memory: (.*)$', t, re.M) or [None, '?'])[1][:40]))
keys = ['us', 'api', 'lua', 'checks', 'noop', 'three', 'fill', 'loop']
print('%-34s' % 'configuration' + ''.join('%9s' % k for k in keys) + '  us per repeat        checksum          bound probes')
for name, rs in sorted(runs.items()):
    med = {k: st.median(r[k] for r in rs) for k in keys}
    print('%-34s' % name + ''.join('%9.2f' % med[k] for k in keys) + '  ' +
          ' '.join('%.2f' % r['us'] for r in rs).ljust(20) + ' ' + rs[0]['checksum'] + '  ' + rs[0]['stopped'])
