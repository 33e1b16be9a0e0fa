#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""An HTTP fault-injecting proxy on loopback, in front of a tile server
(`cityatlas serve` or nginx). For FAULT_SECONDS after the first request it
spoils a share P of the responses, each in one way drawn at random:
500 or 503; a connection reset (RST) before any byte; a body cut in the middle;
a stall of several seconds before the answer; the answer dripped in small
pieces; a Content-Length that lies (longer or shorter than the body). Then it
passes everything through. Independently of that, --fail-first N --fail-match
RE answers the first N requests whose request line matches RE with a 503
(a deterministic fault, e.g. on the root's blocks). One request per connection (it answers with
Connection: close). Writes a JSON log: every request, its fault, and the
wall-clock time the faults stopped.

Usage: fault_proxy.py UPSTREAM_PORT --port-file F --log L [--p 0.5] [--fault-seconds 15] [--seed 1]
                     [--fail-first N --fail-match RE]
Python standard library only (asyncio)."""
import argparse, asyncio, json, random, re, socket, struct, sys, time

FAULTS = ["status_500", "status_503", "reset", "truncate", "stall", "drip", "lie_longer", "lie_shorter"]


async def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("upstream_port", type=int)
    ap.add_argument("--port-file", required=True)
    ap.add_argument("--log", required=True)
    ap.add_argument("--p", type=float, default=0.5)
    ap.add_argument("--fault-seconds", type=float, default=15)
    ap.add_argument("--stall-seconds", type=float, default=4)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--fail-first", type=int, default=0)
    ap.add_argument("--fail-match", default=None)
    a = ap.parse_args()
    fail_match = re.compile(a.fail_match) if a.fail_match else None
    forced_left = [a.fail_first]
    rnd = random.Random(a.seed)
    state = {"first": None, "requests": [], "faults_stopped_at": None}

    def faulting():
        now = time.time()
        if state["first"] is None:
            state["first"] = now
        if now - state["first"] < a.fault_seconds:
            return True
        if state["faults_stopped_at"] is None:
            state["faults_stopped_at"] = state["first"] + a.fault_seconds
        return False

    def save():
        with open(a.log, "w") as f:
            json.dump(state, f)

    async def handle(reader, writer):
        try:
            head = await reader.readuntil(b"\r\n\r\n")
        except Exception:
            writer.close(); return
        line = head.split(b"\r\n", 1)[0].decode("latin-1")
        fault = rnd.choice(FAULTS) if faulting() and rnd.random() < a.p else None
        if fail_match and forced_left[0] > 0 and fail_match.search(line):
            forced_left[0] -= 1
            fault = "status_503"
        state["requests"].append({"t": round(time.time(), 3), "line": line[:120], "fault": fault})
        sock = writer.get_extra_info("socket")
        if fault == "reset":
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            writer.transport.abort(); return
        if fault in ("status_500", "status_503"):
            code = fault[-3:]
            writer.write(f"HTTP/1.1 {code} Injected\r\nContent-Length: 9\r\nConnection: close\r\n\r\ninjected\n".encode())
            await writer.drain(); writer.close(); return
        if fault == "stall":
            await asyncio.sleep(a.stall_seconds)
        # Forward with Connection: close and take the whole answer.
        lines = [l for l in head.split(b"\r\n") if l and not l.lower().startswith(b"connection:")]
        request = b"\r\n".join(lines) + b"\r\nConnection: close\r\n\r\n"
        try:
            ur, uw = await asyncio.open_connection("127.0.0.1", a.upstream_port)
            uw.write(request); await uw.drain()
            answer = await ur.read(-1)
            uw.close()
        except Exception:
            writer.transport.abort(); return
        resp_head, _, body = answer.partition(b"\r\n\r\n")
        hl = [l for l in resp_head.split(b"\r\n") if not l.lower().startswith(b"connection:")]
        if fault in ("lie_longer", "lie_shorter"):
            n = len(body) + 1000 if fault == "lie_longer" else max(0, len(body) // 2)
            hl = [l for l in hl if not l.lower().startswith(b"content-length:")] + [f"Content-Length: {n}".encode()]
        out = b"\r\n".join(hl) + b"\r\nConnection: close\r\n\r\n"
        try:
            if fault == "truncate":
                writer.write(out + body[: len(body) // 2]); await writer.drain()
                writer.transport.abort(); return
            if fault == "drip":
                data = out + body
                for i in range(0, len(data), 256):
                    writer.write(data[i:i + 256]); await writer.drain()
                    await asyncio.sleep(0.01)
            else:
                writer.write(out + body); await writer.drain()
            writer.close()
        except Exception:
            writer.transport.abort()

    server = await asyncio.start_server(handle, "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]
    with open(a.port_file + ".tmp", "w") as f:
        f.write(str(port))
    import os
    os.rename(a.port_file + ".tmp", a.port_file)

    async def saver():
        while True:
            await asyncio.sleep(0.5)
            faulting(); save()

    asyncio.create_task(saver())
    async with server:
        await server.serve_forever()


if __name__ == "__main__":
    try:
        asyncio.run(main())
    except KeyboardInterrupt:
        pass
