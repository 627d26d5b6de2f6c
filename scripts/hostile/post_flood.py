#!/usr/bin/env python3
"""Issue 33 item 2, measured: 8 peers each POST a 32 MB body (Content-Length 32000000: WebSocket++
0.8.2 takes bodies up to that) to a volcast server's page server (TLS, no token), reconnecting when
cut off; meanwhile a native viewer tries to join every 2 s (`volcast view --no-render --frames 1`)
and the server's RSS is sampled every 0.5 s. --no-flood: the same without the flood (baseline).

usage: post_flood.py VOLCAST_BINARY SECONDS [--no-flood]
"""
import socket, ssl, sys, threading

sys.dont_write_bytecode = True  # no __pycache__ in the repository
import common  # noqa: E402

volcast, seconds, flood_on = common.args(__doc__.strip())
run = common.Run(volcast)
run.serve()

stats = {'connections': 0, 'bytes': 0, 'cut': 0}


def flood():
    ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    ctx.check_hostname = False
    ctx.verify_mode = ssl.CERT_NONE
    body = b'x' * (1 << 20)

    def one():
        while not run.stop:
            s = None
            try:
                s = ctx.wrap_socket(socket.create_connection(('127.0.0.1', run.port), timeout=5))
                s.sendall(b'POST / HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 32000000\r\n\r\n')
                stats['connections'] += 1
                for _ in range(31):
                    if run.stop: break
                    s.sendall(body)
                    stats['bytes'] += len(body)
                s.recv(100)
            except (OSError, ssl.SSLError):
                stats['cut'] += 1
            try: s.close()
            except Exception: pass
    for _ in range(8):
        threading.Thread(target=one, daemon=True).start()


base = run.rss_mb()
if flood_on:
    threading.Thread(target=flood, daemon=True).start()
joins = run.start_joins()
samples, peak = run.sample_rss(seconds, base)
run.finish()
line = common.report(run, 'POST', 'bodies', flood_on, seconds, base, samples, peak, stats, joins)
print(f'summary (issue 33 item 2, POST flood {"on" if flood_on else "off"}, {seconds:.0f} s): '
      f'{line}; {stats["bytes"]/1e6:.0f} MB of bodies sent')
