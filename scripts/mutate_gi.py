#!/usr/bin/env python3
"""Mutation check of the GI: applies one plausible formula error at a time to the GI sources, rebuilds
only the test binaries the mutant names, runs them and records whether one of them fails.

    scripts/mutate_gi.py                  # the whole catalogue (scripts/mutants/gi.py), ~1 min a mutant
    scripts/mutate_gi.py --quick          # the quick subset (one mutant per source area, <= 10 min)
    scripts/mutate_gi.py --only ID[,ID]   # chosen mutants
    scripts/mutate_gi.py --list           # the catalogue and whether each anchor matches, no build

Works on a scratch copy of the source tree, build-mutate/src/ (build dir build-mutate/src/build,
RelWithDebInfo); the checkout itself is never edited. Only files whose bytes differ are copied, so
ninja rebuilds exactly what a mutant changed. With ccache (CMAKE_CXX_COMPILER_LAUNCHER=ccache and
base_dir set above the checkout) the copy's first build is mostly cache hits.

A mutant names its place structurally: the enclosing function (a regex for its signature, which must
occur once in the file; the body is the brace block after it) and an expression (literal text, or a
regex) that must occur exactly once inside that body. Outcomes:
  caught     a listed test binary failed (or timed out) on the mutant
  SURVIVED   every listed test passed
  INVALID    an anchor did not match exactly once, the build failed, a shader failed to compile or
             link at run time, or (shared mutants) an implementation no longer agrees with the others
  equivalent listed as such with the reason, and it survived (run to confirm; skipped with --quick)
Each test binary's output is kept in build-mutate/logs/<mutant id>.<binary>.log (agree tests:
<id>.agree.<binary>.log). Prints a Markdown table (also written to build-mutate/mutate_gi.md); exits 1
if a mutant that is not equivalent survived or is invalid, if an equivalent one was caught, or if the
unmutated tests fail.
"""
import argparse
import os
import re
import runpy
import shutil
import subprocess
import sys
import time

CHECKOUT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRATCH = os.path.join(CHECKOUT, 'build-mutate')
ROOT = os.path.join(SCRATCH, 'src')
BUILD = os.path.join(ROOT, 'build')
CATALOGUE = os.path.join(CHECKOUT, 'scripts', 'mutants', 'gi.py')
# A GL test that throws this at run time met a shader the mutant broke: the mutant is invalid, not caught.
SHADER_BROKEN = re.compile(r'shader compilation failed|program link failed')


class AnchorError(Exception):
    pass


def sync_copy():
    """Copies the checkout to ROOT, writing only files whose bytes differ (fresh mtime)."""
    for folder, dirs, files in os.walk(CHECKOUT):
        rel = os.path.relpath(folder, CHECKOUT)
        if rel == '.':
            dirs[:] = [d for d in dirs if not (d.startswith('build') or d in ('.git', 'out'))]
        os.makedirs(os.path.join(ROOT, rel), exist_ok=True)
        for name in files:
            a, b = os.path.join(folder, name), os.path.join(ROOT, rel, name)
            if os.path.islink(a):
                continue
            if not os.path.exists(b) or read(a) != read(b):
                shutil.copyfile(a, b)
                shutil.copymode(a, b)


def read(path):
    with open(path, 'rb') as f:
        return f.read()


def body_span(text, signature):
    """(begin, end) of the brace block that follows the one match of `signature` in `text`."""
    matches = list(re.finditer(signature, text))
    if len(matches) != 1:
        raise AnchorError(f'function /{signature}/ found {len(matches)} times')
    i = text.index('{', matches[0].end())
    depth = 0
    while i < len(text):
        if text.startswith('//', i):
            i = text.index('\n', i)
            continue
        depth += {'{': 1, '}': -1}.get(text[i], 0)
        if depth == 0:
            return matches[0].end(), i + 1
        i += 1
    raise AnchorError(f'function /{signature}/: unbalanced braces')


def mutated_text(text, edit):
    """The file's text with `edit` applied: its expression must match once inside its function."""
    begin, end = body_span(text, edit['fn']) if 'fn' in edit else (0, len(text))
    pattern = edit['regex'] if 'regex' in edit else re.escape(edit['text'])
    matches = list(re.finditer(pattern, text[begin:end]))
    if len(matches) != 1:
        where = f"in /{edit['fn']}/" if 'fn' in edit else 'in the file'
        raise AnchorError(f"{edit['file']}: /{pattern[:60]}/ found {len(matches)} times {where}")
    m = matches[0]
    return text[:begin + m.start()] + m.expand(edit['to']) + text[begin + m.end():]


def apply_edits(edits):
    """Applies every edit (several per file allowed); returns {path: original bytes} for restore()."""
    originals, texts = {}, {}
    for edit in edits:
        path = os.path.join(ROOT, edit['file'])
        if path not in texts:
            originals[path] = read(path)
            texts[path] = originals[path].decode()
        texts[path] = mutated_text(texts[path], edit)
    for path, text in texts.items():
        with open(path, 'w') as f:
            f.write(text)
    return originals


def anchor_status(mutant):
    """'ok' or why the mutant's edits do not apply to the checkout (read only)."""
    texts = {}
    try:
        for edit in mutant['edits']:
            path = os.path.join(CHECKOUT, edit['file'])
            texts[path] = mutated_text(texts.get(path) or read(path).decode(), edit)
    except AnchorError as e:
        return f'ANCHOR: {e}'
    return 'ok'


def restore(originals):
    for path, data in originals.items():
        with open(path, 'wb') as f:
            f.write(data)


def binary_of(target):
    for folder, _, files in os.walk(os.path.join(BUILD, 'tests')):
        if target in files:
            return os.path.join(folder, target)
    raise FileNotFoundError(f'mutate_gi.py: no test binary {target} in {BUILD}/tests')


def split_spec(spec):
    """'binary' or 'binary:gtest filter'."""
    target, _, gtest_filter = spec.partition(':')
    return target, gtest_filter


def build(targets):
    """(ok, tail of the log) after building the targets."""
    p = subprocess.run(['ninja', '-C', BUILD, '-j2', *sorted(set(targets))], capture_output=True, text=True)
    return p.returncode == 0, (p.stdout + p.stderr)[-3000:]


def run_test(spec, timeout, log_name):
    """'pass', 'broken' (a shader did not compile) or the failure as 'binary (n failed)'/'(timeout)'.
    The output goes to build-mutate/logs/<log_name>.<binary>.log."""
    target, gtest_filter = split_spec(spec)
    args = [binary_of(target)] + ([f'--gtest_filter={gtest_filter}'] if gtest_filter else [])
    try:
        p = subprocess.run(args, cwd=BUILD, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return f'{spec} (timeout)'
    os.makedirs(os.path.join(SCRATCH, 'logs'), exist_ok=True)
    with open(os.path.join(SCRATCH, 'logs', f'{log_name}.{target}.log'), 'w') as f:
        f.write(p.stdout + p.stderr)
    if re.search(r'Running 0 tests', p.stdout):
        return f'{spec} (selects no test)'
    if p.returncode == 0:
        return 'pass'
    if SHADER_BROKEN.search(p.stdout + p.stderr):
        return 'broken'
    failed = len(re.findall(r'^\[  FAILED  \] .*\)$', p.stdout, re.M))
    return f'{spec} ({failed} failed)'


def run_tests(specs, timeout, log_name):
    """(failures, broken) over the test specs."""
    results = [run_test(s, timeout, log_name) for s in specs]
    return [r for r in results if r not in ('pass', 'broken')], 'broken' in results


def targets_of(mutant):
    return [split_spec(s)[0] for s in mutant['tests'] + mutant.get('agree', [])]


def judge(mutant, timeout):
    """(outcome, detail) of one applied mutant."""
    ok, log = build(targets_of(mutant))
    if not ok:
        return 'INVALID', 'build failed: ' + ' '.join(l for l in log.splitlines() if 'error:' in l)[:300]
    disagree, broken = run_tests(mutant.get('agree', []), timeout, mutant['id'] + '.agree')
    failures, broken_too = run_tests(mutant['tests'], timeout, mutant['id'])
    if broken or broken_too:
        return 'INVALID', 'shader does not compile'
    if disagree:  # what the listed tests said is kept for the record
        listed = ', '.join(failures) or 'pass'
        return 'INVALID', f"implementations disagree: {', '.join(disagree)}; listed tests: {listed}"
    if 'equivalent' in mutant:
        return ('caught', 'LISTED EQUIVALENT BUT CAUGHT: ' + ', '.join(failures)) if failures else \
            ('equivalent', mutant['equivalent'])
    return ('caught', ', '.join(failures)) if failures else ('SURVIVED', '')


def run_mutant(mutant, timeout):
    try:
        originals = apply_edits(mutant['edits'])
    except AnchorError as e:
        return 'INVALID', f'anchor: {e}'
    try:
        return judge(mutant, timeout)
    finally:
        restore(originals)


def failed(mutant, outcome):
    """Whether the outcome fails the run: a survivor, an invalid mutant, or an 'equivalent' one caught."""
    return outcome in ('SURVIVED', 'INVALID') or (outcome == 'caught' and 'equivalent' in mutant)


def baseline(mutants, timeout):
    """Builds and runs every test the chosen mutants name, unmutated; exits if one fails."""
    specs = sorted({s for m in mutants for s in m['tests'] + m.get('agree', [])})
    ok, log = build([split_spec(s)[0] for s in specs])
    if not ok:
        sys.exit('mutate_gi.py: the unmutated build fails:\n' + log)
    failures, broken = run_tests(specs, timeout, 'unmutated')
    if failures or broken:
        sys.exit('mutate_gi.py: the unmutated tests fail: ' + ', '.join(failures))


def table_row(m, outcome, detail, seconds):
    kind = 'shared' if len({e['file'] for e in m['edits']}) > 1 else ''
    files = ', '.join(sorted({'`' + os.path.basename(e['file']) + '`' for e in m['edits']}))
    cells = [m['id'], m['area'], m['what'], f'{files} {kind}', outcome, detail, f'{seconds:.0f}']
    return '| ' + ' | '.join(c.replace('|', r'\|') for c in cells) + ' |'


def choose(mutants, args):
    if args.only:
        ids = args.only.split(',')
        unknown = set(ids) - {m['id'] for m in mutants}
        if unknown:
            sys.exit(f'mutate_gi.py: no mutant {sorted(unknown)}')
        return [m for m in mutants if m['id'] in ids]
    if args.quick:
        return [m for m in mutants if m.get('quick') and 'equivalent' not in m]
    return mutants


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true', help='the quick subset only')
    parser.add_argument('--only', help='comma-separated mutant ids')
    parser.add_argument('--list', action='store_true', help='print the catalogue and exit')
    parser.add_argument('--timeout', type=int, default=600, help='seconds per test binary (default 600)')
    args = parser.parse_args()
    mutants = choose(runpy.run_path(CATALOGUE)['MUTANTS'], args)
    if args.list:
        for m in mutants:
            print(f"{m['id']:20} {anchor_status(m):4} {m['area']:24} {m['what']}  -> {', '.join(m['tests'])}")
        return 0
    sync_copy()
    subprocess.run(['cmake', '-S', ROOT, '-B', BUILD, '-G', 'Ninja', '-DCMAKE_BUILD_TYPE=RelWithDebInfo'],
                   check=True, stdout=subprocess.DEVNULL)
    start = time.time()
    baseline(mutants, args.timeout)
    print(f'unmutated tests pass ({time.time() - start:.0f} s)', flush=True)
    rows, bad, counts = [], 0, {}
    for i, m in enumerate(mutants, 1):
        began = time.time()
        outcome, detail = run_mutant(m, args.timeout)
        seconds = time.time() - began
        counts[outcome] = counts.get(outcome, 0) + 1
        bad += failed(m, outcome)
        print(f"[{i}/{len(mutants)}] {m['id']}: {outcome} {detail} ({seconds:.0f} s)", flush=True)
        rows.append(table_row(m, outcome, detail, seconds))
    head = ['| id | area | mutation | file(s) | outcome | failing tests (or reason) | s |',
            '|---|---|---|---|---|---|---|']
    summary = ', '.join(f'{n} {o}' for o, n in sorted(counts.items()))
    text = '\n'.join(head + rows) + f'\n\n{len(mutants)} mutants: {summary}; {time.time() - start:.0f} s in all\n'
    print(text)
    with open(os.path.join(SCRATCH, 'mutate_gi.md'), 'w') as f:
        f.write(text)
    return 1 if bad else 0


if __name__ == '__main__':
    sys.exit(main())
