#!/usr/bin/env python3
"""Where the test phase's CPU goes: every ctest test of the dev build, run two at a time, with its
wall time and its CPU time (user + system of the test and of every process it waited for).

    python3 scripts/test_cpu.py [--regex R] [--alone R] > cpu.txt

--regex R: only the tests whose name matches R (as ctest -R).
--alone R: the tests matching R are run one at a time, after the others, with the whole machine's
           busy time (/proc/stat) beside theirs: a browser test's Chromium is not waited for by
           the test (so not in its rusage) but is on the machine. Run it on a quiet machine.

Prints one line per test, costliest first: CPU s, wall s, machine-busy s (alone only, else -),
exit status, name, labels; then the sums. The test environment (ASAN_OPTIONS, working folder) is
the one ctest gives each test (its ENVIRONMENT and WORKING_DIRECTORY properties); DISABLED tests
are skipped as ctest skips them.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import threading
import time


def machine_busy_s():
    with open('/proc/stat') as f:
        fields = [int(x) for x in f.readline().split()[1:]]
    user, nice, system, _idle, _iowait, irq, softirq = fields[:7]
    return (user + nice + system + irq + softirq) / os.sysconf('SC_CLK_TCK')


def run(test):
    props = {p['name']: p['value'] for p in test.get('properties', [])}
    env = dict(os.environ)
    for e in props.get('ENVIRONMENT', []):
        key, value = e.split('=', 1)
        env[key] = value
    started = time.time()
    p = subprocess.Popen(test['command'], cwd=props.get('WORKING_DIRECTORY', '.'), env=env,
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(p.pid, 0)
    return (usage.ru_utime + usage.ru_stime, time.time() - started,
            os.waitstatus_to_exitcode(status), ','.join(props.get('LABELS', [])))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--regex', default='')
    ap.add_argument('--alone', default='')
    ap.add_argument('--build', default='build/dev')
    args = ap.parse_args()
    listing = subprocess.run(['ctest', '--show-only=json-v1'], cwd=args.build, check=True,
                             capture_output=True, text=True).stdout
    tests = [t for t in json.loads(listing)['tests']
             if 'DISABLED_' not in t['name'] and re.search(args.regex, t['name'])
             and not any(p['name'] == 'DISABLED' and p['value'] for p in t.get('properties', []))]
    alone = [t for t in tests if args.alone and re.search(args.alone, t['name'])]
    together = [t for t in tests if t not in alone]
    rows, lock = [], threading.Lock()

    def worker():
        while True:
            with lock:
                if not together:
                    return
                t = together.pop(0)
            cpu, wall, rc, labels = run(t)
            with lock:
                rows.append((cpu, wall, None, rc, t['name'], labels))
                print(f'{len(rows)}/{len(tests)} {t["name"]}', file=sys.stderr)

    threads = [threading.Thread(target=worker) for _ in range(2)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for t in alone:
        before = machine_busy_s()
        cpu, wall, rc, labels = run(t)
        rows.append((cpu, wall, machine_busy_s() - before, rc, t['name'], labels))
        print(f'{len(rows)}/{len(tests)} {t["name"]} (alone)', file=sys.stderr)
    rows.sort(key=lambda r: -(r[2] if r[2] is not None else r[0]))
    for cpu, wall, busy, rc, name, labels in rows:
        shown = f'{busy:7.1f}' if busy is not None else '      -'
        print(f'{cpu:7.1f} {wall:7.1f} {shown} {rc:3d} {name} {labels}')
    cpu = sum(r[2] if r[2] is not None else r[0] for r in rows)
    print(f'# {len(rows)} tests: {cpu:.1f} CPU s (machine-busy for those run alone), '
          f'{sum(r[1] for r in rows):.1f} wall s summed; failed: '
          f'{sum(1 for r in rows if r[3] != 0)}')


if __name__ == '__main__':
    main()
