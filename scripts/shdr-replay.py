#!/usr/bin/env python3
"""Serve a recorded SHDR log over TCP as an MTConnect adapter does (test helper).

Usage: shdr-replay.py LOG [--start-line N] [--seconds S] [--speed F] [--cut-after-s S]
                       [--mark-time ISO]
Binds 127.0.0.1 on a free port and prints `PORT <n>` on stdout, then waits for one client and
sends the data lines of the window (from the first timestamped line at or after --start-line,
for --seconds of log time) at their recorded timing divided by --speed. Multi-line asset
bodies are sent as they are. `* PING` from the client is answered `* PONG 10000`, as adapters
do. --cut-after-s closes the connection that many log seconds into the window (a dropped
adapter). --mark-time prints `MARK <unix time>` (wall clock, s) just after the first line
stamped at or after that log time was sent (for end-to-end delays). At the end the connection is held open until the client leaves (or --close).
"""
import argparse, datetime, socket, sys, threading, time


def ts(line):
    head = line.split("|", 1)[0].split("@")[0].strip()
    try:
        return datetime.datetime.fromisoformat(head.replace("Z", "+00:00")).timestamp()
    except ValueError:
        return None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("log")
    ap.add_argument("--start-line", type=int, default=1)
    ap.add_argument("--seconds", type=float, default=1e12)
    ap.add_argument("--speed", type=float, default=1.0)
    ap.add_argument("--cut-after-s", type=float, default=None)
    ap.add_argument("--close", action="store_true")
    ap.add_argument("--mark-time", default=None)
    a = ap.parse_args()
    lines = open(a.log, encoding="utf-8", errors="replace").read().splitlines()[a.start_line - 1:]
    window, t0 = [], None
    for l in lines:
        t = ts(l)
        if t0 is None:
            if t is None:
                continue
            t0 = t
        if t is not None and t - t0 > a.seconds:
            break
        window.append((t, l))
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)
    print("PORT", srv.getsockname()[1], flush=True)
    conn, _ = srv.accept()
    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    lock = threading.Lock()
    mark = ts(a.mark_time) if a.mark_time else None

    def reader():
        buf = b""
        while True:
            try:
                d = conn.recv(4096)
            except OSError:
                return
            if not d:
                return
            buf += d
            while b"\n" in buf:
                l, buf = buf.split(b"\n", 1)
                if l.strip() == b"* PING":
                    with lock:
                        try:
                            conn.sendall(b"* PONG 10000\n")
                        except OSError:
                            return

    threading.Thread(target=reader, daemon=True).start()
    start = time.monotonic()
    last_t = t0
    for t, l in window:
        if t is not None:
            # Log time only moves forward in the schedule (back-steps are sent at once).
            last_t = max(last_t, t)
            if a.cut_after_s is not None and last_t - t0 > a.cut_after_s:
                conn.shutdown(socket.SHUT_RDWR)
                conn.close()
                print("CUT", flush=True)
                time.sleep(3600)
            delay = start + (last_t - t0) / a.speed - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        with lock:
            try:
                conn.sendall((l + "\n").encode())
            except OSError:
                # The client left (e.g. watch --once after its test): nothing more to serve.
                print("GONE", flush=True)
                return
        if mark is not None and t is not None and t >= mark:
            print("MARK", repr(time.time()), flush=True)
            mark = None
    print("DONE", len(window), flush=True)
    if a.close:
        conn.close()
        return
    try:
        while conn.recv(4096):
            pass
    except OSError:
        pass


if __name__ == "__main__":
    main()
