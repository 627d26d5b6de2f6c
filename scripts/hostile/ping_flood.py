#!/usr/bin/env python3
"""Issue 33 item 1, measured: one peer floods a volcast server's browser path (TLS, WebSocket on
/stream, no Hello) with 125-byte pings as fast as it can, never reading, reconnecting when cut
off; meanwhile a native viewer tries to join every 2 s (`volcast view --no-render --frames 1`)
and the server's RSS is sampled every 0.5 s. --no-flood: the same without the flood (baseline).

usage: ping_flood.py VOLCAST_BINARY SECONDS [--no-flood]
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
    ping = bytes([0x89, 0x80 | 125, 1, 2, 3, 4]) + bytes(b ^ [1, 2, 3, 4][i % 4] for i, b in enumerate(b'p' * 125))
    batch = ping * 500
    while not run.stop:
        s = None
        try:
            s = ctx.wrap_socket(socket.create_connection(('127.0.0.1', run.port), timeout=5))
            s.sendall(b'GET /stream HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n'
                      b'Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n'
                      b'Sec-WebSocket-Version: 13\r\n\r\n')
            head = b''
            while b'\r\n\r\n' not in head:
                c = s.recv(1)
                if not c: raise OSError('closed')
                head += c
            stats['connections'] += 1
            while not run.stop:
                s.sendall(batch)
                stats['bytes'] += len(batch)
        except (OSError, ssl.SSLError):
            stats['cut'] += 1
        try: s.close()
        except Exception: pass


base = run.rss_mb()
if flood_on:
    threading.Thread(target=flood, daemon=True).start()
joins = run.start_joins()
samples, peak = run.sample_rss(seconds, base)
run.finish()
line = common.report(run, 'WebSocket', 'pings', flood_on, seconds, base, samples, peak, stats, joins)
print(f'summary (issue 33 item 1, ping flood {"on" if flood_on else "off"}, {seconds:.0f} s): '
      f'{line}; {stats["bytes"]/1e6:.0f} MB of pings sent')
