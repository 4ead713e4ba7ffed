"""Summary of a --compare-models sweep (sweep.py's JSONL): python report.py CASES.jsonl

For each case, the recommended model's fit is judged against the true model's fit on the same
views by their projection errors against the true camera over the whole image (`grid_rms`):
the recommendation is *worse* when its error exceeds twice the true model's fit's and the true
model's fit by more than the noise (sigma px): a systematic error the noise does not explain.
`worse, rule before`: the same count for the recommendation the rule before the fallback to models
folding within the validity margin would make on the same rows. *Needlessly complex*: a valid
model with fewer parameters than the recommended one is not worse (by the same judgement).
Replayed rules (among the valid models only, no fallback, on the rows' per-view held-out errors):
the 2% rule, calib's (compare.rs `as_good_as`: within 2% and not systematically worse by the
paired test, with k times Student's t; k=1 is calib's) and the paired test without the 2%. `worse(seen)`: the same judgement over the image cells where corners were seen (interpolation).
"""
import json, sys, math
from collections import Counter, defaultdict
import numpy as np

PINHOLE = {'brown-conrady4', 'brown-conrady5', 'rational8', 'thin-prism12'}
SHORT = {'brown-conrady4': 'bc4', 'brown-conrady5': 'bc5', 'kannala-brandt4': 'kb4',
         'rational8': 'rat8', 'thin-prism12': 'tp12', None: 'none'}


ORDER = ['brown-conrady4', 'brown-conrady5', 'kannala-brandt4', 'rational8', 'thin-prism12']


def rule_before(rows):
    """The rule before the fallback to models folding within the margin (calib before this
    bench): the fewest parameters among the valid models within 2% of the best valid one."""
    valid = [m for m in ORDER if m in rows and rows[m]['valid'] and rows[m]['cv'] is not None]
    if not valid:
        return None
    best = min(rows[m]['cv'] for m in valid)
    within = [m for m in valid if rows[m]['cv'] <= best * 1.02]
    return min(within, key=lambda m: (rows[m]['params'], ORDER.index(m)))


T975 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
        2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
        2.060, 2.056, 2.052, 2.048, 2.045, 2.042]


def paired(a, b):
    """compare.rs `paired_excess`: (mean log ratio of the views' held-out squared errors, its
    standard error, views)."""
    hb = {v: e for v, e, _ in b['held_out']}
    d = np.array([math.log(e / hb[v]) if e > 0 and hb[v] > 0 else math.nan
                  for v, e, _ in a['held_out'] if v in hb])
    if len(d) < 3 or not np.all(np.isfinite(d)):
        return None
    return d.mean(), math.sqrt(d.var(ddof=1) / len(d)), len(d)


def rule_paired(k, within_2=True):
    """calib's rule with k times its factor (`within_2` False: the paired test alone), among the
    valid models (no fallback)."""
    def rule(rows):
        valid = [m for m in ORDER if m in rows and rows[m]['valid'] and rows[m]['cv'] is not None]
        if not valid or not all(rows[m].get('held_out') for m in valid):
            return None
        best = min(valid, key=lambda m: rows[m]['cv'])

        def as_good(m):
            if m == best:
                return True
            t = paired(rows[m], rows[best])
            w2 = rows[m]['cv'] <= rows[best]['cv'] * 1.02
            if t is None:
                return w2
            f = T975[t[2] - 2] if t[2] - 1 <= len(T975) else 1.96
            return (w2 or not within_2) and t[0] <= k * f * t[1]
        return min((m for m in valid if as_good(m)), key=lambda m: (rows[m]['params'], ORDER.index(m)))
    return rule


def needless(rec, rule=None):
    """The recommendation has more parameters than a valid model whose fit is not worse."""
    rows = rec['rows']
    m = rec.get('recommended') if rule is None else rule(rows)
    if m is None:
        return False
    t = rows.get(rec['model'], {}).get('grid_rms')
    if t is None:
        return False
    fine = [o for o, r in rows.items() if r['valid'] and r.get('grid_rms') is not None
            and not (r['grid_rms'] > 2 * t and r['grid_rms'] > t + rec['noise'])]
    return any(rows[o]['params'] < rows[m]['params'] for o in fine)


def worse(rec, key, rule=None):
    """(recommended error, true model's fit error, is worse) by `key` ('grid_rms', 'covered_rms');
    the recommendation of the binary, or of `rule(rows)`."""
    rows = rec['rows']
    m = rec.get('recommended') if rule is None else rule(rows)
    t = rows.get(rec['model'], {}).get(key)
    if m is None or t is None:
        return None
    e = rows[m].get(key)
    if e is None:
        return None
    return e, t, (e > 2 * t and e > t + rec['noise'])


def main(path):
    recs = [json.loads(l) for l in open(path)]
    out = []
    p = out.append
    lenses = list(dict.fromkeys(r['lens'] for r in recs))
    bad = [r for r in recs if r.get('compare_rc') != 0 or 'synth_error' in r]
    nan = [r for r in recs if any(isinstance(v, float) and math.isnan(v)
                                  for row in r.get('rows', {}).values() for v in (row.get('cv'), row.get('rms')) if v is not None)]
    mism = [r for r in recs for m, row in r.get('rows', {}).items()
            if row.get('rms') is not None and row.get('fit_rms') is not None and abs(row['rms'] - row['fit_rms']) > 1e-9]
    p(f'{len(recs)} cases; compare-models failed (exit code) on {len(bad)}; NaN in a row on {len(nan)}; '
      f'row RMS differing from `calib single --model` on {len(mism)}')
    p('')
    p('Recommended models, and the recommended fit against the true model\'s fit over the image '
      '(worse: error > 2x and > +noise; ratio = recommended / true fit, grid RMS px)')
    p(f"{'lens':<16} {'cases':>5}  {'recommended (count)':<40} {'none':>4} {'worse':>5} {'worse(seen)':>11} {'median ratio':>12} {'max ratio':>10} {'worse, rule before':>18}")
    for tilt_low in (False, True):
        p('-- tilt 45 deg' if not tilt_low else '-- tilt 10 and 5 deg (8 and 15 views, 0.3 px)')
        for lens in lenses:
            rs = [r for r in recs if r['lens'] == lens and (r['tilt'] < 45) == tilt_low and 'rows' in r]
            if not rs:
                continue
            c = Counter(SHORT[r.get('recommended')] for r in rs)
            rec_s = ' '.join(f'{k}:{v}' for k, v in sorted(c.items(), key=lambda kv: -kv[1]) if k != 'none')
            j = [worse(r, 'grid_rms') for r in rs]
            js = [worse(r, 'covered_rms') for r in rs]
            ratios = [a / b for a, b, _ in filter(None, j) if b > 0]
            p(f"{lens:<16} {len(rs):>5}  {rec_s:<40} {c.get('none', 0):>4} {sum(1 for x in j if x and x[2]):>5} "
              f"{sum(1 for x in js if x and x[2]):>11} {np.median(ratios) if ratios else float('nan'):>12.2f} {max(ratios) if ratios else float('nan'):>10.3g} "
              f"{sum(1 for r in rs if (x := worse(r, 'grid_rms', rule_before)) and x[2]):>18}")
    p('')
    p('All tilts (docs/camera-model.md, "Choosing a model"):')
    p('')
    p('| true lens | cases | recommended | worse | needlessly complex | worse, rule before |')
    p('|---|---|---|---|---|---|')
    for lens in lenses:
        rs = [r for r in recs if r['lens'] == lens and 'rows' in r]
        c = Counter(SHORT[r.get('recommended')] for r in rs)
        rec_s = ', '.join(f'{k} {v}' for k, v in sorted(c.items(), key=lambda kv: -kv[1]))
        w = sum(1 for r in rs if (x := worse(r, 'grid_rms')) and x[2])
        wb = sum(1 for r in rs if (x := worse(r, 'grid_rms', rule_before)) and x[2])
        nc = sum(1 for r in rs if needless(r))
        p(f'| {lens} | {len(rs)} | {rec_s} | {w} | {nc} | {wb} |')
    rs = [r for r in recs if 'rows' in r]
    p(f"| all | {len(rs)} | | {sum(1 for r in rs if (x := worse(r, 'grid_rms')) and x[2])} | "
      f"{sum(1 for r in rs if needless(r))} | {sum(1 for r in rs if (x := worse(r, 'grid_rms', rule_before)) and x[2])} |")
    p('')
    if all(r['rows'][m].get('held_out') for r in rs for m in r['rows'] if r['rows'][m]['cv'] is not None):
        p('Replayed among the valid models (no fallback): worse / needlessly complex, by views (all lenses and tilts)')
        rules = ([('2% rule', rule_before)] + [(f'2% & paired k={k}', rule_paired(k)) for k in (0.5, 1, 2)]
                 + [('paired alone', rule_paired(1, False))])
        p(f"{'rule':<20}" + ''.join(f'{f"{v} views":>12}' for v in (5, 8, 15, 30)) + f"{'all':>12}")
        for name, rule in rules:
            line = f'{name:<20}'
            for v in (5, 8, 15, 30, None):
                sub = [r for r in rs if v is None or r['views'] == v]
                w = sum(1 for r in sub if (x := worse(r, 'grid_rms', rule)) and x[2])
                n = sum(1 for r in sub if needless(r, rule))
                line += f'{f"{w} / {n}":>12}'
            p(line)
    p('')
    p('Worse recommendations by views and noise (tilt 45): worse / cases')
    hdr = f"{'lens':<16}" + ''.join(f'{f"{v}v {n}px":>11}' for v in (5, 8, 15, 30) for n in (0.1, 0.3, 1.0))
    p(hdr)
    for lens in lenses:
        line = f'{lens:<16}'
        for v in (5, 8, 15, 30):
            for n in (0.1, 0.3, 1.0):
                rs = [r for r in recs if r['lens'] == lens and r['tilt'] == 45 and r['views'] == v and r['noise'] == n and 'rows' in r]
                w = sum(1 for r in rs if (x := worse(r, 'grid_rms')) and x[2])
                none = sum(1 for r in rs if r.get('recommended') is None)
                line += f"{f'{w}/{len(rs)}' + (f' n{none}' if none else ''):>11}"
        p(line)
    p('(nN: N cases without a recommendation)')
    p('')
    fish_before = [r for r in recs if r['model'] == 'kannala-brandt4' and 'rows' in r and rule_before(r['rows']) in PINHOLE]
    p(f"fisheye lenses with a pinhole model recommended by the rule before: {len(fish_before)}, by lens "
      + ' '.join(f'{k}:{v}' for k, v in Counter(r['lens'] for r in fish_before).items()))
    fish_pin = [r for r in recs if r['model'] == 'kannala-brandt4' and r.get('recommended') in PINHOLE]
    p(f'fisheye lenses with a pinhole model recommended: {len(fish_pin)} of '
      f"{sum(1 for r in recs if r['model'] == 'kannala-brandt4')}: "
      + ', '.join(f"{r['lens']} {r['views']}v {r['noise']}px t{r['tilt']} s{r['seed']} -> {SHORT[r['recommended']]}" for r in fish_pin[:8]))
    p('')
    # Noise of the cross-validated RMS: how far the TRUE model's CV lies above the best CV, and
    # how often a model within the tolerance is clearly worse over the image.
    p('Cross-validated RMS of the true model relative to the best one (cv_true / cv_best - 1), median and 90th percentile, tilt 45:')
    for v in (5, 8, 15, 30):
        line = f'  {v:>2} views:'
        for n in (0.1, 0.3, 1.0):
            xs = []
            for r in recs:
                if r['views'] != v or r['noise'] != n or r['tilt'] != 45 or 'rows' not in r:
                    continue
                cvs = [row['cv'] for row in r['rows'].values() if row.get('cv') is not None]
                ct = r['rows'][r['model']].get('cv')
                if cvs and ct is not None:
                    xs.append(ct / min(cvs) - 1)
            if xs:
                line += f'  {n} px: {100 * np.median(xs):.1f}% / {100 * np.percentile(xs, 90):.1f}%'
        p(line)
    p('')
    p('Noise of the cross-validated RMS between two adequate models: brown-conrady5 against brown-conrady4 on the '
      'brown-conrady4 lenses (cv_bc5 / cv_bc4 - 1), median and 90th percentile of its absolute value, tilt 45:')
    for v in (5, 8, 15, 30):
        line = f'  {v:>2} views:'
        for n in (0.1, 0.3, 1.0):
            xs = [abs(r['rows']['brown-conrady5']['cv'] / r['rows']['brown-conrady4']['cv'] - 1) for r in recs
                  if r['model'] == 'brown-conrady4' and r['views'] == v and r['noise'] == n and r['tilt'] == 45
                  and 'rows' in r and r['rows']['brown-conrady5'].get('cv') and r['rows']['brown-conrady4'].get('cv')]
            if xs:
                line += f'  {n} px: {100 * np.median(xs):.1f}% / {100 * np.percentile(xs, 90):.1f}% (n={len(xs)})'
        p(line)
    p('')
    # Was the user told? The recommended row's poor-coverage warning, and the table's line on
    # equally fitting models disagreeing where no corner was seen (its advice when the
    # disagreement exceeds the recommended model's cross-validated RMS).
    p('Told where the views do not reach (recommended row): poor-coverage warning / disagreement line '
      '/ its advice (disagreement above the cross-validated RMS); worse and not worse recommendations:')
    for label, want in (('worse', True), ('not worse', False)):
        rs = [r for r in recs if r.get('recommended') and (x := worse(r, 'grid_rms')) and x[2] == want]
        warned = sum(1 for r in rs if 'poor-coverage' in r['rows'][r['recommended']]['warn'])
        lined = [r for r in rs if r.get('uncovered_disagreement')]
        advised = [r for r in lined
                   if r['uncovered_disagreement']['pixels'] > (r['rows'][r['recommended']].get('cv') or 0)]
        p(f'  {label:<9}: {len(rs)} cases: warned {warned}, disagreement line {len(lined)}, advice {len(advised)}')
    # By how wrong the recommended fit is somewhere over the image (its largest error against
    # the truth): how many cases get the line, and with 1 px or more.
    for lo, hi in ((0, 1), (1, 5), (5, np.inf)):
        rs = [r for r in recs if r.get('recommended')
              and (e := r['rows'][r['recommended']].get('grid_max')) is not None and lo <= e < hi]
        lined = [r for r in rs if r.get('uncovered_disagreement')]
        big = [r for r in lined if r['uncovered_disagreement']['pixels'] >= 1.0]
        p(f'  recommended fit\'s largest error {lo} to {hi} px: {len(rs)} cases, disagreement line {len(lined)}, '
          f'of 1 px or more {len(big)}')
    ratios = [r['uncovered_disagreement']['pixels'] / e for r in recs
              if r.get('recommended') and r.get('uncovered_disagreement')
              and (e := r['rows'][r['recommended']].get('grid_max')) and np.isfinite(e)]
    if ratios:
        p(f'  disagreement / recommended model\'s largest error over the image against the truth: median {np.median(ratios):.2f}, '
          f'10th-90th percentile {np.percentile(ratios, 10):.2f} to {np.percentile(ratios, 90):.2f} (n={len(ratios)})')
    p('')
    gaps = [r for r in recs if r.get('gap_to_best_fit') is not None and r['gap_to_best_fit'] > 0.02]
    p(f"gap_to_best_fit above 2% (the 'no model both fits' message): {len(gaps)} cases; "
      + 'by lens ' + ' '.join(f'{k}:{v}' for k, v in Counter(r['lens'] for r in gaps).items()))
    nonerec = [r for r in recs if 'rows' in r and r.get('recommended') is None]
    msgs = Counter(r['compare_table'].strip().splitlines()[-1][:90] for r in nonerec)
    p(f'no recommendation: {len(nonerec)} cases: ' + '; '.join(f'{v}x "{k}"' for k, v in msgs.items()))
    p('')
    p('Time of --compare-models (s, one thread): median / max by views')
    for v in (5, 8, 15, 30):
        ts = [r['compare_seconds'] for r in recs if r['views'] == v and 'compare_seconds' in r]
        tf = [r['compare_seconds'] for r in recs if r['views'] == v and 'compare_seconds' in r and r['model'] == 'kannala-brandt4']
        p(f'  {v:>2} views: {np.median(ts):.2f} / {max(ts):.2f}  (fisheye lenses {np.median(tf):.2f} / {max(tf):.2f})')
    print('\n'.join(out))


if __name__ == '__main__':
    main(sys.argv[1])
