#!/usr/bin/env python3
"""A small MTConnect agent for the live tests of feedscope (test helper, loopback only).

Usage: mtconnect-test-agent.py --devices Devices.xml --log LOG.shdr [--buffer N] [--speed F]
                               [--start-on-sample] [--journal FILE]
                               [--count-refusal clamp|cppagent|cppagent-legacy|package]

Serves /probe, /current and /sample?from=&count= on 127.0.0.1 (a free port, printed as
`PORT <n>` on stdout) with documents built by the PyPI package `mtconnect` (0.3.3), fed with
the observations of a recorded SHDR log:
- --speed F > 0: a thread feeds the log at its recorded timing divided by F (from the start,
  or from the first /sample request with --start-on-sample); `DONE <lines>` on stdout at the
  end. --speed 0 (default): nothing is fed until `/feed?lines=N` feeds the next N lines.
- --buffer N: the agent's buffer (observations); a small one makes OUT_OF_RANGE happen.
- `/restart`: the agent restarts (a new instanceId, a new buffer from sequence 1; the feed
  goes on into it), as cppagent does when restarted.
- --count-refusal: what a /sample whose count exceeds the buffer gets. `clamp` (default): the
  count is lowered to the buffer size and served. `cppagent`: refused as cppagent 2.x refuses
  it (src/mtconnect/sink/rest_sink/rest_service.cpp, RestService::fetchSampleData's
  `checkRange(printer, count, lowerCountLimit, upperCountLimit, "count", true)` with
  upperCountLimit = bufferSize + 1; src/mtconnect/sink/rest_sink/error.hpp, OutOfRange::make;
  src/mtconnect/printer/xml_printer.cpp, printErrors): HTTP 400, an MTConnectError whose
  Header has bufferSize but no sequence numbers, and, schema 2.6 and later, an <OutOfRange
  errorCode="OUT_OF_RANGE"> with ErrorMessage `'count' must be less than <bufferSize+1>` and
  a QueryParameter name="count" (Value, Minimum, Maximum). `cppagent-legacy`: the same before
  schema 2.6 (Error::makeLegacyError): <Error errorCode="OUT_OF_RANGE">'count' must be less
  than <bufferSize+1></Error>. `package`: what the `mtconnect` package's own sample() says:
  MTInvalidRange `Count must not be greater than <bufferSize>`, HTTP 400.
- `/status`: `instanceId firstSequence lastSequence nextSequence linesFed linesTotal
  sampleRequests countRefusals` (the /sample requests answered, and those refused for count).
- --journal FILE: one line per observation put into the buffer:
  `instanceId sequence dataItemId timestamp value` (the oracle of the tests).
Observation timestamps are the log's own text (several observations of a line share one).
Exits when stdin closes or on SIGTERM.

The package has bugs for this use; each is worked round below where it bites (search for
"mtconnect 0.3.3:").
"""
import argparse
import datetime
import http.server
import os
import sys
import threading
import time
import urllib.parse

# mtconnect 0.3.3: its device reader calls Element.getchildren(), removed in Python 3.9. The C
# Element type cannot be given the method back, so the pure-Python ElementTree is loaded
# instead (blocking the C accelerator before the first import of the package) and the method
# is added to its Element class.
for m in [k for k in sys.modules if k.startswith("xml.etree")]:
    del sys.modules[m]
sys.modules["_elementtree"] = None
from xml.etree import ElementTree as ET  # noqa: E402

if not hasattr(ET.Element, "getchildren"):
    ET.Element.getchildren = lambda self: list(self)

import mtconnect.agent as mt_agent  # noqa: E402
import mtconnect.device as mt_device  # noqa: E402
import mtconnect.error as mt_error  # noqa: E402
import mtconnect.storage as mt_storage  # noqa: E402
import mtconnect.xmlhelper as mt_xml  # noqa: E402
from mtconnect.loghandler import MTLogger  # noqa: E402

MTLogger.disabled = True


def strip_namespaces(root):
    for e in root.iter():
        if isinstance(e.tag, str) and "}" in e.tag:
            e.tag = e.tag.split("}", 1)[1]
    return root


def devices_file(path, tmpdir):
    """The Devices element of a Devices.xml, namespaces stripped, as a file of its own.

    mtconnect 0.3.3: read_devices() takes every child of the document root as a device, i.e.
    expects <Devices> as the root, not the standard <MTConnectDevices><Header/><Devices>; it
    also finds children by bare tag names, so the MTConnect namespace must go. And it refuses
    data item types missing from its own list (an MTConnect 1.3 subset): the file's types are
    added to that list.
    """
    root = strip_namespaces(ET.parse(path).getroot())
    devices = root if root.tag == "Devices" else root.find("Devices")
    for d in devices.iter("DataItem"):
        t = d.get("type")
        if t and t not in mt_device.MTC_DataID_list:
            mt_device.MTC_DataID_list.append(t)
    out = os.path.join(tmpdir, "Devices.stripped.xml")
    ET.ElementTree(devices).write(out)
    return out


class OutOfRange(mt_error.MTError):
    # mtconnect 0.3.3: errors are named MTInvalidRange / MTInvalidRequest; MTConnect's code
    # for a `from` outside the buffer is OUT_OF_RANGE.
    name = "OUT_OF_RANGE"


class InvalidRequest(mt_error.MTError):
    name = "INVALID_REQUEST"


def cppagent_count_error(agent, uri, count, legacy):
    """cppagent 2.x's refusal of a count above the buffer (see --count-refusal)."""
    size = agent.buffer.size()
    text = "'count' must be less than {}".format(size + 1)
    root = ET.Element("MTConnectError")
    # cppagent's error header: instanceId, bufferSize..., no first/next/lastSequence.
    root.append(mt_agent.MTConnect.get_header(agent))
    errors = ET.SubElement(root, "Errors")
    if legacy:
        e = ET.SubElement(errors, "Error", errorCode="OUT_OF_RANGE")
        e.text = text
    else:
        e = ET.SubElement(errors, "OutOfRange", errorCode="OUT_OF_RANGE")
        ET.SubElement(e, "URI").text = uri
        ET.SubElement(e, "Request").text = "MTConnectStreams"
        ET.SubElement(e, "ErrorMessage").text = text
        qp = ET.SubElement(e, "QueryParameter", name="count")
        ET.SubElement(qp, "Value").text = str(count)
        ET.SubElement(qp, "Minimum").text = str(-size)
        ET.SubElement(qp, "Maximum").text = str(size)
    return ET.tostring(root).decode()


def _time_str(self):
    # mtconnect 0.3.3: timestamps are the time of the push in whole seconds; here every
    # observation carries the log's own timestamp text (set in Agent.push and Agent.__init__).
    if isinstance(self.timestamp, str):
        return self.timestamp
    return self.timestamp.strftime("%Y-%m-%dT%H:%M:%S.%fZ")


mt_storage.MTDataEntity.get_time_str = _time_str


class Agent(mt_agent.MTConnect):
    def __init__(self, devices, buffer, start_time, count_refusal="clamp"):
        self.count_refusal = count_refusal
        self.refused_count = 0
        # mtconnect 0.3.3: item_dict and component_dict are class attributes that __init__
        # updates in place: a second agent (a restart) would share the first one's items.
        self.item_dict = {}
        self.component_dict = {}
        # mtconnect 0.3.3: MTDataItem.data_list is a class-level list; MTGeneric.__init__
        # shadows it per instance, which this relies on (checked below).
        os.environ["BUFFER_SIZE"] = str(buffer)
        super().__init__(loc=devices, hostname="http://127.0.0.1")
        # The UNAVAILABLE every item starts with, stamped with the log's time at the start
        # (a real agent stamps them with its start; the log's clock is the one here).
        for e in self.buffer.buffer:
            if e is not None:
                e.timestamp = start_time
        # mtconnect 0.3.3: a ComponentStream's name is set from the component's name even when
        # it has none, and the document then fails to serialize: such components are streamed
        # under their id (the name attribute is optional in MTConnect; clients go by ids).
        for c in self.component_dict.values():
            if c.name is None:
                c.name = c.id
        items = list(self.item_dict.values())
        assert len({id(i.data_list) for i in items}) == len(items), "shared data_list"
        self.by_key = {}
        for item in items:
            self.by_key[item.id] = item
            if item.name:
                self.by_key.setdefault(item.name, item)
        self.header_next = None

    def push(self, item, value, timestamp):
        e = mt_storage.MTDataEntity(item, value)
        e.timestamp = timestamp
        self.buffer.push(e)
        return e.sequence_number

    def get_header(self):
        # mtconnect 0.3.3: the header has no firstSequence, lastSequence nor nextSequence,
        # which a client needs to follow the stream.
        h = super().get_header()
        b = self.buffer
        h.set("firstSequence", str(b.first_sequence))
        h.set("lastSequence", str(b.last_sequence))
        h.set("nextSequence", str(self.header_next or b.last_sequence + 1))
        return h

    def error(self, cls, text, status):
        self.header_next = None
        return cls(self, text).to_xml(), status

    def current_doc(self):
        self.header_next = None
        r = self.current()
        return r.get_xml(), r.get_status()

    def sample_doc(self, start, count, uri="/sample"):
        """/sample?from=start&count=count by MTConnect's rules.

        mtconnect 0.3.3: its sample() reads `from` as exclusive (it returns start+1 ..
        start+count), refuses from = nextSequence (an empty answer for a client that is up to
        date) and a count above the buffer size; the document is built here from the
        package's own parts (its item lists, stream formatting and header)."""
        b = self.buffer
        if start is None:
            start = b.first_sequence
        if count is None:
            count = 100
        if count <= 0:
            return self.error(InvalidRequest, "count must be positive", 400)
        if start < b.first_sequence or start > b.last_sequence + 1:
            return self.error(
                OutOfRange,
                "'from' must be between {} and {}".format(b.first_sequence, b.last_sequence + 1),
                404,
            )
        # A count above the buffer: clamped, or refused as --count-refusal says (cppagent checks
        # `from` first, then `count`, as here).
        if count > b.size():
            mode = self.count_refusal
            self.refused_count = int(mode != "clamp")
            if mode in ("cppagent", "cppagent-legacy"):
                self.header_next = None
                return cppagent_count_error(self, uri, count, mode == "cppagent-legacy"), 400
            if mode == "package":
                return self.error(mt_error.MTInvalidRange,
                                  "Count must not be greater than {}".format(b.size()), 400)
        count = min(count, b.size())
        end = min(start + count - 1, b.last_sequence)
        groups = {}
        for item in self.get_item_list(None):
            data = item.get_data(start - 1, end)  # the package's (exclusive, inclusive]
            if not data:
                continue
            comp = groups.setdefault(item.device, {}).setdefault(item.parent_component, {})
            comp.setdefault(item.category, []).append(data)
        streams = self.format_stream_xml(groups)
        root = ET.Element("MTConnectStreams")
        self.header_next = end + 1
        root.append(self.get_header())
        self.header_next = None
        root.append(streams)
        return ET.tostring(root).decode(), 200


def shdr_lines(path):
    """(time text, unix s, tokens) of the data lines of an SHDR log; asset bodies skipped."""
    out, tag = [], None
    for line in open(path, encoding="utf-8", errors="replace").read().splitlines():
        if tag is not None:
            if line.strip() == tag:
                tag = None
            continue
        if not line.strip() or line.startswith("*"):
            continue
        tokens = line.split("|")
        head = tokens[0].split("@")[0].strip()
        try:
            t = datetime.datetime.fromisoformat(head.replace("Z", "+00:00"))
        except ValueError:
            continue
        if len(tokens) > 1 and tokens[1].startswith("@"):
            if tokens[-1].startswith("--multiline--"):
                tag = tokens[-1]
            continue
        out.append((head, t.timestamp(), tokens[1:]))
    return out


class Server:
    def __init__(self, a, tmpdir):
        self.a = a
        self.devices = devices_file(a.devices, tmpdir)
        self.lock = threading.Lock()
        self.lines = shdr_lines(a.log)
        self.agent = Agent(self.devices, a.buffer, self.lines[0][0], a.count_refusal)
        self.sample_requests = 0
        self.count_refusals = 0
        self.fed = 0
        self.skipped = 0
        self.journal = open(a.journal, "w") if a.journal else None
        self.started = threading.Event()

    def push_line(self, text, tokens):
        ag = self.agent
        i = 0
        while i < len(tokens):
            key = tokens[i].split(":", 1)[-1]
            item = ag.by_key.get(key)
            # Fields after the key: CONDITION level|native code|severity|qualifier|text,
            # MESSAGE native code|text, anything else one value.
            n = 1
            if item is not None and item.category == "CONDITION":
                n = 5
            elif item is not None and item.type in ("MESSAGE", "ALARM"):
                n = 2
            fields = tokens[i + 1:i + 1 + n]
            i += 1 + n
            if item is None or not fields:
                continue
            if item.category == "SAMPLE":
                v = fields[0].strip()
                if v != "UNAVAILABLE":
                    try:
                        v = float(v)
                    except ValueError:
                        # A 3-D PATH_POSITION, an empty value: the package takes numbers only.
                        self.skipped += 1
                        continue
            elif item.category == "CONDITION":
                v = fields[0].strip().upper()
                if v not in ("UNAVAILABLE", "NORMAL", "WARNING", "FAULT"):
                    self.skipped += 1
                    continue
            else:
                v = fields[-1]
            seq = ag.push(item, v, text)
            if self.journal:
                self.journal.write("{} {} {} {} {}\n".format(ag.instanceId, seq, item.id, text, v))
        if self.journal:
            self.journal.flush()

    def feed(self, n):
        with self.lock:
            k = 0
            while k < n and self.fed < len(self.lines):
                text, _, tokens = self.lines[self.fed]
                self.push_line(text, tokens)
                self.fed += 1
                k += 1
            return k

    def run_timed(self):
        if self.a.start_on_sample:
            self.started.wait()
        t0 = self.lines[0][1] if self.lines else 0
        start = time.monotonic()
        last = t0
        while self.fed < len(self.lines):
            t = self.lines[self.fed][1]
            last = max(last, t)
            delay = start + (last - t0) / self.a.speed - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            self.feed(1)
        print("DONE", self.fed, flush=True)

    def restart(self):
        with self.lock:
            self.agent = Agent(self.devices, self.a.buffer, self.lines[max(self.fed - 1, 0)][0],
                               self.a.count_refusal)
            return self.agent.instanceId

    def status(self):
        with self.lock:
            b = self.agent.buffer
            return "{} {} {} {} {} {} {} {}".format(self.agent.instanceId, b.first_sequence,
                                                    b.last_sequence, b.last_sequence + 1,
                                                    self.fed, len(self.lines),
                                                    self.sample_requests, self.count_refusals)


def make_handler(srv):
    class Handler(http.server.BaseHTTPRequestHandler):
        def log_message(self, *args):
            pass

        def reply(self, body, status=200, xml=True):
            data = body.encode()
            self.send_response(status)
            self.send_header("Content-Type", "text/xml" if xml else "text/plain")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

        def do_GET(self):
            u = urllib.parse.urlparse(self.path)
            q = urllib.parse.parse_qs(u.query)

            def num(k):
                return int(q[k][0]) if k in q else None

            try:
                if u.path == "/probe":
                    with srv.lock:
                        r = srv.agent.probe()
                    return self.reply(r.get_xml(), r.get_status())
                if u.path == "/current":
                    with srv.lock:
                        body, st = srv.agent.current_doc()
                    return self.reply(body, st)
                if u.path == "/sample":
                    srv.started.set()
                    with srv.lock:
                        body, st = srv.agent.sample_doc(num("from"), num("count"), self.path)
                        srv.sample_requests += 1
                        srv.count_refusals += srv.agent.refused_count
                        srv.agent.refused_count = 0
                    return self.reply(body, st)
                if u.path == "/feed":
                    return self.reply("OK {}".format(srv.feed(num("lines") or 1)), xml=False)
                if u.path == "/restart":
                    return self.reply("OK {}".format(srv.restart()), xml=False)
                if u.path == "/status":
                    return self.reply(srv.status(), xml=False)
                return self.reply("no such endpoint", 404, xml=False)
            except ValueError as e:
                with srv.lock:
                    body, st = srv.agent.error(InvalidRequest, str(e), 400)
                return self.reply(body, st)

    return Handler


def main():
    import tempfile

    ap = argparse.ArgumentParser()
    ap.add_argument("--devices", required=True)
    ap.add_argument("--log", required=True)
    ap.add_argument("--buffer", type=int, default=131072)
    ap.add_argument("--speed", type=float, default=0.0)
    ap.add_argument("--start-on-sample", action="store_true")
    ap.add_argument("--journal")
    ap.add_argument("--count-refusal", default="clamp",
                    choices=["clamp", "cppagent", "cppagent-legacy", "package"])
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        srv = Server(a, tmp)
        httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), make_handler(srv))
        httpd.daemon_threads = True
        threading.Thread(target=httpd.serve_forever, daemon=True).start()
        if a.speed > 0:
            threading.Thread(target=srv.run_timed, daemon=True).start()
        print("PORT", httpd.server_address[1], flush=True)
        # Live until the test closes stdin (or kills the process).
        sys.stdin.read()


if __name__ == "__main__":
    main()
