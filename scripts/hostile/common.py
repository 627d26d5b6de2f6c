"""Shared by ping_flood.py and post_flood.py: a volcast server on the hands sequence (browser path
on, port 0), its RSS, a native viewer joining every 2 s, and clean-up of everything started."""
import atexit, os, re, shutil, signal, subprocess, sys, tempfile, threading, time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, '..', '..'))
DATA = os.environ.get('VOLCAST_DATA',
                      os.path.normpath(os.path.join(REPO, '..', 'shared', 'data')))
HANDS = os.path.join(DATA, 'rgbd-hands-640x360')


class Run:
    """A temporary folder (config: certificate, pinned servers) and the processes started in it."""

    def __init__(self, volcast):
        self.volcast = volcast
        self.tmp = tempfile.mkdtemp(prefix='volcast-hostile-')
        self.env = dict(os.environ, XDG_CONFIG_HOME=os.path.join(self.tmp, 'config'),
                        ASAN_OPTIONS=os.environ.get('ASAN_OPTIONS', 'detect_leaks=0'))
        self.procs = []
        self.server = None
        self.link = None
        self.port = None
        self.log = []
        self.stop = False
        atexit.register(self.close)
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: sys.exit(130))

    def close(self):
        self.stop = True
        for p in list(self.procs):
            if p.poll() is None:
                p.terminate()
        for p in list(self.procs):
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        self.procs = []
        shutil.rmtree(self.tmp, ignore_errors=True)

    def popen(self, args, **kw):
        p = subprocess.Popen(args, env=self.env, **kw)
        self.procs.append(p)
        return p

    def serve(self):
        """`volcast serve` with the browser path (--web: the page folder built or installed with
        the binary) on a free port; waits for its join link."""
        self.server = self.popen([self.volcast, 'serve', '--source', HANDS, '--port', '0',
                                  '--bind', '127.0.0.1', '--web', '--fps', '30'],
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)

        def pump_log():
            for line in self.server.stdout:
                self.log.append(line)
                m = re.search(r'(volcast://\S+)', line)
                if m and self.link is None:
                    self.link = m.group(1)
        threading.Thread(target=pump_log, daemon=True).start()
        t0 = time.time()
        while self.link is None and time.time() - t0 < 60 and self.server.poll() is None:
            time.sleep(0.1)
        if self.link is None:
            sys.exit('volcast serve printed no join link:\n' + ''.join(self.log))
        self.port = int(re.match(r'volcast://[^/]*:(\d+)/', self.link).group(1))
        time.sleep(1.0)

    def rss_mb(self):
        with open(f'/proc/{self.server.pid}/status') as f:
            for line in f:
                if line.startswith('VmRSS:'):
                    return int(line.split()[1]) / 1024
        return -1

    def start_joins(self):
        """A native viewer joins every 2 s (`view --no-render --frames 1`); returns the list of
        (seconds to the first frame set, exit status) it fills."""
        joins = []

        def viewer_loop():
            while not self.stop:
                start = time.time()
                p = self.popen([self.volcast, 'view', '--connect', self.link, '--no-render',
                                '--frames', '1', '--connect-timeout', '10000'],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                try:
                    rc = p.wait(timeout=60)
                except subprocess.TimeoutExpired:
                    p.kill()
                    rc = p.wait()
                self.procs.remove(p)
                joins.append((round(time.time() - start, 2), rc))
                time.sleep(max(0, 2 - (time.time() - start)))
        threading.Thread(target=viewer_loop, daemon=True).start()
        return joins

    def sample_rss(self, seconds, base):
        """Samples the server's RSS every 0.5 s for SECONDS; returns (samples, peak, at least
        BASE)."""
        peak = base
        samples = []
        t0 = time.time()
        while time.time() - t0 < seconds:
            time.sleep(0.5)
            r = self.rss_mb()
            samples.append(round(r))
            peak = max(peak, r)
        return samples, peak

    def finish(self):
        """Stops the floods and the joins, then the server."""
        self.stop = True
        time.sleep(2.5)
        self.server.terminate()
        self.server.wait(timeout=30)

    def failures(self):
        lim = [l for l in self.log if 'over the limit' in l or 'failed' in l]
        return ''.join(lim[:3]).strip()


def args(usage):
    if len(sys.argv) < 2 or sys.argv[1] in ('-h', '--help'):
        sys.exit(usage)
    volcast = os.path.abspath(sys.argv[1])
    rest = [a for a in sys.argv[2:] if a != '--no-flood']
    if len(rest) != 1:
        sys.exit(usage)
    seconds = float(rest[0])
    return volcast, seconds, '--no-flood' not in sys.argv


def report(run, kind, what, flood_on, seconds, base, samples, peak, stats, joins):
    ok = [t for t, rc in joins if rc == 0]
    print(f'binary {run.volcast}: flood {"on" if flood_on else "off"} {seconds:.0f} s')
    print(f'  server RSS: {base:.0f} MB before, peak {peak:.0f} MB; samples {samples}')
    print(f'  flood: {stats["connections"]} {kind} connections opened, '
          f'{stats["bytes"]/1e6:.0f} MB of {what} sent, cut off {stats["cut"]} times')
    print(f'  native joins (view --frames 1, s to first frame set, rc): {joins}')
    print(f'  joined {len(ok)} of {len(joins)}; within 1 s: {sum(1 for t in ok if t <= 1.0)}')
    print('  server log (failures):', run.failures())
    return (f'server RSS {base:.0f} -> peak {peak:.0f} MB; native viewers joined {len(ok)} of '
            f'{len(joins)}, {sum(1 for t in ok if t <= 1.0)} within 1 s')
