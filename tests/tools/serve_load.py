#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Load on `cityatlas serve` over loopback: CLIENTS concurrent clients for
SECONDS, each looping over a mix of valid requests (whole files on keep-alive
connections, single byte ranges, HEAD, a request on a half-closed socket) and
hostile ones (encoded '..', NUL, an overlong path, a symlink out, a slow and an
abandoned request). Every valid response is checked against the file's bytes;
every hostile one must be refused (no 200). The server's open file descriptors
and resident memory are sampled before, after warm-up and at the end.

Usage: serve_load.py URL FOLDER PID [--clients 64] [--seconds 20] [--json OUT]
Exit 1 on any failed valid request, any hostile request served, or fd growth.
Python standard library only."""
import argparse, http.client, json, os, random, socket, sys, threading, time
from urllib.parse import urlparse


def sample(pid):
    fds = len(os.listdir(f"/proc/{pid}/fd"))
    rss_kb = 0
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                rss_kb = int(line.split()[1])
    return {"fds": fds, "rss_mb": round(rss_kb / 1024, 1)}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("url"); ap.add_argument("folder"); ap.add_argument("pid", type=int)
    ap.add_argument("--clients", type=int, default=64)
    ap.add_argument("--seconds", type=float, default=20)
    ap.add_argument("--json")
    a = ap.parse_args()
    u = urlparse(a.url)
    host, port = u.hostname, u.port
    files = []
    for root, _, names in os.walk(a.folder):
        for n in names:
            p = os.path.join(root, n)
            if os.path.isfile(p) and not os.path.islink(p):
                files.append(os.path.relpath(p, a.folder))
    data = {f: open(os.path.join(a.folder, f), "rb").read() for f in files}
    hostile = ["/%2e%2e/%2e%2e/etc/passwd", "/geometry/..%2f..%2f..%2fetc%2fpasswd", "/tileset.json%00.txt",
               "/" + "a/" * 40000 + "x", "/%2E%2E%2F%2E%2E%2Fetc/passwd"]
    if os.path.islink(os.path.join(a.folder, "leak")):
        hostile.append("/leak")
    stats = {"valid": 0, "valid_failed": 0, "hostile": 0, "hostile_served": 0, "bytes": 0, "errors": [],
             "half_closed": 0, "half_closed_answered": 0, "idle_closed_retried": 0}
    lock = threading.Lock()
    stop = time.time() + a.seconds

    def note(kind, ok, detail=""):
        with lock:
            stats[kind] += 1
            if not ok:
                stats[kind + ("_failed" if kind == "valid" else "_served")] += 1
                if len(stats["errors"]) < 20:
                    stats["errors"].append(detail)

    def request(conn, method, path, headers=None):
        """One request on a keep-alive connection. A connection the server
        closed while idle (its keep-alive timeout) is retried once on a new
        one, as HTTP/1.1 lets clients do for idempotent requests (RFC 9112
        9.3.1) and as browsers and curl do; counted apart."""
        for attempt in (0, 1):
            try:
                conn.request(method, path, headers=headers or {})
                resp = conn.getresponse()
                return resp, resp.read()
            except (http.client.RemoteDisconnected, ConnectionResetError, BrokenPipeError):
                conn.close()
                if attempt == 1:
                    raise
                with lock:
                    stats["idle_closed_retried"] += 1

    def client(seed):
        rnd = random.Random(seed)
        conn = http.client.HTTPConnection(host, port, timeout=30)
        while time.time() < stop:
            r = rnd.random()
            f = rnd.choice(files)
            body = data[f]
            try:
                if r < 0.45:  # whole file, keep-alive connection
                    resp, got = request(conn, "GET", "/" + f)
                    note("valid", resp.status == 200 and got == body, f"GET {f}: {resp.status}, {len(got)} of {len(body)} bytes")
                    with lock: stats["bytes"] += len(got)
                elif r < 0.7 and len(body) > 1:  # a single byte range
                    lo = rnd.randrange(len(body)); hi = rnd.randrange(lo, len(body))
                    resp, got = request(conn, "GET", "/" + f, {"Range": f"bytes={lo}-{hi}"})
                    note("valid", resp.status == 206 and got == body[lo:hi + 1], f"Range {lo}-{hi} of {f}: {resp.status}")
                elif r < 0.8:  # HEAD
                    resp, _ = request(conn, "HEAD", "/" + f)
                    note("valid", resp.status == 200 and int(resp.getheader("Content-Length", -1)) == len(body), f"HEAD {f}: {resp.status}")
                elif r < 0.88:  # half-closed: request, shutdown(SHUT_WR), read to the end
                    s = socket.create_connection((host, port), timeout=30)
                    s.sendall(f"GET /{f} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n".encode())
                    s.shutdown(socket.SHUT_WR)
                    chunks = []
                    while True:
                        c = s.recv(65536)
                        if not c: break
                        chunks.append(c)
                    s.close()
                    raw = b"".join(chunks)
                    head, _, rest = raw.partition(b"\r\n\r\n")
                    # A valid request like any other (RFC 9112 §9.6): no answer
                    # is a failure. (cpp-httplib 0.11, serve's server until stop
                    # 26, took the peer for gone and sent nothing.)
                    with lock:
                        stats["half_closed"] += 1
                        stats["half_closed_answered"] += bool(raw)
                    note("valid", head.startswith(b"HTTP/1.1 200") and rest == body, f"half-closed GET {f}: {head[:40]!r}")
                elif r < 0.96:  # hostile
                    p = rnd.choice(hostile)
                    s = socket.create_connection((host, port), timeout=30)
                    s.sendall(f"GET {p} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n".encode())
                    raw = b""
                    while True:
                        c = s.recv(65536)
                        if not c: break
                        raw += c
                    s.close()
                    note("hostile", not raw.startswith(b"HTTP/1.1 200") and b"root:" not in raw, f"{p[:60]}: {raw[:40]!r}")
                else:  # abandoned: half a request line, then gone
                    s = socket.create_connection((host, port), timeout=30)
                    s.sendall(b"GET /tileset.js")
                    time.sleep(rnd.random() * 0.05)
                    s.close()
            except Exception as e:  # a failed valid request (connection errors count)
                note("valid", False, f"{type(e).__name__}: {e}")
                conn.close()
                conn = http.client.HTTPConnection(host, port, timeout=30)
        conn.close()

    before = sample(a.pid)
    warm_stop = stop
    stop = time.time() + min(2.0, a.seconds / 4)
    threads = [threading.Thread(target=client, args=(i,)) for i in range(a.clients)]
    for t in threads: t.start()
    for t in threads: t.join()
    warm = sample(a.pid)
    stop = time.time() + a.seconds
    t0 = time.time()
    threads = [threading.Thread(target=client, args=(1000 + i,)) for i in range(a.clients)]
    for t in threads: t.start()
    mid = None
    time.sleep(a.seconds / 2); mid = sample(a.pid)
    for t in threads: t.join()
    elapsed = time.time() - t0
    time.sleep(1.0)  # connections the server closes after the clients
    after = sample(a.pid)
    out = {"clients": a.clients, "seconds": round(elapsed, 1), "requests_per_s": round((stats["valid"] + stats["hostile"]) / elapsed),
           "valid": stats["valid"], "valid_failed": stats["valid_failed"], "hostile": stats["hostile"],
           "hostile_served": stats["hostile_served"], "mb_served": round(stats["bytes"] / 1e6, 1),
           "half_closed": stats["half_closed"], "half_closed_answered": stats["half_closed_answered"],
           "idle_closed_retried": stats["idle_closed_retried"],
           "server": {"before": before, "after_warmup": warm, "mid_load": mid, "after": after},
           "errors": stats["errors"]}
    print(json.dumps(out, indent=1))
    if a.json:
        with open(a.json, "w") as f: json.dump(out, f, indent=1)
    fd_growth = after["fds"] - before["fds"]
    ok = stats["valid_failed"] == 0 and stats["hostile_served"] == 0 and fd_growth <= 2 and stats["valid"] > 0
    if not ok:
        print(f"FAIL: {stats['valid_failed']} valid requests failed, {stats['hostile_served']} hostile served, fd growth {fd_growth}", file=sys.stderr)
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
