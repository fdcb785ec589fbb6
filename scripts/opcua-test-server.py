#!/usr/bin/env python3
"""A real OPC UA server (PyPI `asyncua`) that publishes a feedscope trace as a control would.

Used by crates/feedscope-live/tests/opcua.rs (run them with scripts/opcua-tests.sh).

It listens on opc.tcp://127.0.0.1:PORT/feedscope/ with security None and anonymous access,
and offers, in namespace `urn:feedscope:opcua-test` (index 2):

    ns=2;s=X.ActPos       axis actual position (Double, mm)
    ns=2;s=X.ActTorque    motor torque (Double, N·m)          (torque traces)
    ns=2;s=X.ActCurrent   motor current (Double, A)           (current traces)
    ns=2;s=X.ActLoad      drive load (Double, % of --rated-torque-nm)
    ns=2;s=Channel.ProgName  the program name (String)

Each variable starts with status BadWaitingForInitialData. Every row of the trace is then
written at its own time, wall clock = EPOCH + time_s / SPEED, with SourceTimestamp =
EPOCH + time_s (the trace's time, not sped up) and ServerTimestamp = the wall clock.

Stopping and restarting: kill the process and start it again with the same --port and
--epoch (and --repeat); it skips the rows whose time has passed and carries on, as a control would after a
server restart. After the last row it keeps serving until killed.

--string-at T: at trace time T (of the whole, repeated run) the position node gets one String
value ("E-STOP"; a wrongly typed value, as a misconfigured node or gateway delivers), then the
trace goes on as Doubles.

With FEEDSCOPE_TEST_SERVER_LOG set, asyncua logs at INFO level to stderr.

On stdout, once listening:  `listening PORT epoch EPOCH rows N`
The trace: feedscope's long layout (time_s,channel,value) or wide layout
(time_s,position_mm,torque_nm|current_a).
"""

import argparse
import asyncio
import csv
import datetime
import socket
import sys
import time

import logging
import os

from asyncua import Server, ua

CHANNEL_NODES = {
    "position_mm": "X.ActPos",
    "torque_nm": "X.ActTorque",
    "current_a": "X.ActCurrent",
}


def read_trace(path):
    """Rows (time_s, channel, value), sorted by time."""
    rows = []
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        cols = reader.fieldnames or []
        long_layout = cols[:3] == ["time_s", "channel", "value"]
        for rec in reader:
            t = float(rec["time_s"])
            if long_layout:
                rows.append((t, rec["channel"], float(rec["value"])))
            else:
                for c in cols[1:]:
                    if rec[c] != "":
                        rows.append((t, c, float(rec[c])))
    for _, c, _ in rows:
        if c not in CHANNEL_NODES:
            sys.exit(f"{path}: channel {c!r} is not one of {sorted(CHANNEL_NODES)}")
    rows.sort(key=lambda r: r[0])
    return rows


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stamp(t):
    return datetime.datetime.fromtimestamp(t, datetime.timezone.utc)


async def main():
    if os.environ.get("FEEDSCOPE_TEST_SERVER_LOG"):
        logging.basicConfig(level=logging.INFO)
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--csv", required=True, help="the trace (feedscope simulate's trace.csv)")
    p.add_argument("--port", type=int, default=0, help="TCP port; 0 picks a free one")
    p.add_argument("--epoch", type=float, default=None,
                   help="control time (s since the Unix epoch) of trace time 0; default 1 s after listening")
    p.add_argument("--speed", type=float, default=1.0, help="replay speed factor")
    p.add_argument("--rated-torque-nm", type=float, default=5.0,
                   help="torque of 100 %% load, for X.ActLoad")
    p.add_argument("--repeat", type=int, default=1,
                   help="publish the trace this many times back to back (a longer run for restarts)")
    p.add_argument("--secure", metavar="DIR", default=None,
                   help="offer only Basic256Sha256 SignAndEncrypt; write the server's and a client's "
                        "key (PEM) and certificate (DER) to DIR (client-key.pem, client-cert.der)")
    p.add_argument("--program", default="IDLE_STROKE.MPF", help="program name written at trace time 0")
    p.add_argument("--string-at", type=float, default=None, metavar="T",
                   help="write one String value on the position node at trace time T")
    a = p.parse_args()

    rows = read_trace(a.csv)
    # Back to back: each repetition starts one sample interval (of the first channel) after
    # the previous one ended.
    first = sorted(t for t, c, _ in rows if c == rows[0][1])
    step = first[1] - first[0] if len(first) > 1 else 1.0
    period = max(r[0] for r in rows) - rows[0][0] + step
    rows = [(t + k * period, c, v) for k in range(a.repeat) for t, c, v in rows]
    port = a.port or free_port()

    server = Server()
    await server.init()
    server.set_endpoint(f"opc.tcp://127.0.0.1:{port}/feedscope/")
    server.set_server_name("feedscope OPC UA test server")
    if a.secure:
        from pathlib import Path
        from cryptography.x509.oid import ExtendedKeyUsageOID
        from asyncua.crypto.cert_gen import setup_self_signed_certificate
        d = Path(a.secure)
        d.mkdir(parents=True, exist_ok=True)
        subject = {"organizationName": "feedscope tests"}
        # Host name 127.0.0.1, the endpoint's: async-opcua checks it against the certificate.
        await setup_self_signed_certificate(
            d / "server-key.pem", d / "server-cert.der", "urn:feedscope:opcua-test-server",
            "127.0.0.1", [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH], subject)
        # The client's: the application URI async-opcua's client announces (urn:feedscope:client).
        await setup_self_signed_certificate(
            d / "client-key.pem", d / "client-cert.der", "urn:feedscope:client",
            "localhost", [ExtendedKeyUsageOID.CLIENT_AUTH], subject)
        # The certificate's URI must be the server's application URI (checked by the client).
        await server.set_application_uri("urn:feedscope:opcua-test-server")
        await server.load_certificate(str(d / "server-cert.der"))
        await server.load_private_key(str(d / "server-key.pem"))
        server.set_security_policy([ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt])
    else:
        server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
    idx = await server.register_namespace("urn:feedscope:opcua-test")
    objects = server.nodes.objects
    axis = await objects.add_object(ua.NodeId("X", idx), ua.QualifiedName("X", idx))
    channel = await objects.add_object(ua.NodeId("Channel", idx), ua.QualifiedName("Channel", idx))
    nodes = {}
    for name in ["X.ActPos", "X.ActTorque", "X.ActCurrent", "X.ActLoad"]:
        nodes[name] = await axis.add_variable(
            ua.NodeId(name, idx), ua.QualifiedName(name.split(".")[1], idx),
            ua.Variant(0.0, ua.VariantType.Double))
    nodes["Channel.ProgName"] = await channel.add_variable(
        ua.NodeId("Channel.ProgName", idx), ua.QualifiedName("ProgName", idx),
        ua.Variant("", ua.VariantType.String))

    async with server:
        now = time.time()
        for node in nodes.values():
            await server.write_attribute_value(node.nodeid, ua.DataValue(
                StatusCode=ua.StatusCode(ua.StatusCodes.BadWaitingForInitialData),
                SourceTimestamp=stamp(now), ServerTimestamp=stamp(now)))
        epoch = a.epoch if a.epoch is not None else round(time.time() + 1.0, 6)
        print(f"listening {port} epoch {epoch:.6f} rows {len(rows)}", flush=True)

        async def write(name, value, t, vtype):
            wall = time.time()
            await server.write_attribute_value(nodes[name].nodeid, ua.DataValue(
                Value=ua.Variant(value, vtype), SourceTimestamp=stamp(t), ServerTimestamp=stamp(wall)))

        program_written = False
        string_due = a.string_at
        serving_since = time.time()
        for t, c, v in rows:
            due = epoch + t / a.speed
            # Rows due before this server started passed while it was down: lost, as on a real
            # control. A row that falls due while the previous writes were slow (a busy
            # machine) is written late, not dropped: dropping those (due < now) lost a torque
            # sample now and then under CPU load.
            if due < serving_since:
                continue
            await asyncio.sleep(max(0.0, due - time.time()))
            if not program_written:
                await write("Channel.ProgName", a.program, epoch + t, ua.VariantType.String)
                program_written = True
            if string_due is not None and t >= string_due:
                await asyncio.sleep(max(0.0, epoch + string_due / a.speed - time.time()))
                # asyncua refuses a write whose variant type differs from the stored value's
                # unless that value is None: the stored value is cleared in its address space
                # (no notification goes out), so that the String is sent as a misbehaving
                # server or gateway would send it.
                held = server.iserver.aspace._nodes[nodes["X.ActPos"].nodeid].attributes[
                    ua.AttributeIds.Value]
                held.value = None
                await write("X.ActPos", "E-STOP", epoch + string_due, ua.VariantType.String)
                held.value = None  # and back to Doubles
                print(f"string written at {string_due}", flush=True)
                string_due = None
            await write(CHANNEL_NODES[c], v, epoch + t, ua.VariantType.Double)
            if c == "torque_nm":
                await write("X.ActLoad", v / a.rated_torque_nm * 100.0, epoch + t, ua.VariantType.Double)
        print("trace done", flush=True)
        while True:
            await asyncio.sleep(3600)


if __name__ == "__main__":
    try:
        asyncio.run(main())
    except KeyboardInterrupt:
        pass
