#!/usr/bin/env python3
"""Per diagnosis round, the significant candidates' likelihood ratios, best first, and the gap
between the first two: where the gap is within the search's chi-square(1) threshold (about 12.5
at the default alpha and budget) the round judged the two as rivals (diagnose::Rivals).
docs/diagnosis.md "Session 19" uses it on the blind surveys' directories.

    python3 scripts/diagnose-margins.py SURVEY_DIR [SURVEY_DIR ...]   # reads */*-diag/diagnosis.json
"""
import glob
import json
import os
import sys

for d in sys.argv[1:]:
    for f in sorted(glob.glob(d + '/*-diag/diagnosis.json')):
        name = os.path.basename(os.path.dirname(f))[:-5]
        rounds = json.load(open(f))['search']['rounds']
        for i, rd in enumerate(rounds):
            sig = sorted(((t['likelihood_ratio'] - t['threshold'], t['effect'], t['likelihood_ratio'])
                          for t in rd['tests'] if t.get('significant')), reverse=True)
            if not sig:
                continue
            gap = sig[0][2] - sig[1][2] if len(sig) > 1 else float('nan')
            rivals = rd.get('rivals')
            judged = ''
            if rivals:
                judged = '  rivals: chose %s%s' % (rivals['chosen'], '' if rivals['told_apart'] else ' (not told apart)')
            print('%-34s round %d added %-20s gap %9.1f : %s%s' % (
                name, i + 1, rd.get('added'), gap,
                ' | '.join('%s %.1f' % (e, lr) for _, e, lr in sig[:3]), judged))
