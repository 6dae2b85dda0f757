#!/usr/bin/python3
"""Attributes the datagrams a lossy link dropped to the DDS writers whose samples they carried,
and lays them beside what the recorder says it missed (docs/measurements/deployment_recorder_link.md, "The lossy
recorder link").

  dropped_datagrams.py --pcap LOGS/dropped.pcap --recorder-log LOGS/hexa-recorder.log

dropped.pcap: `hexa_multihost_bench --capture-drops` (the loss rule logs every packet it drops
to an nflog group; tcpdump in the lossy host's namespace writes them, link type NFLOG).
The recorder's log: its stop summary (per topic received / missing) and its "matched writer
TOPIC GUID RELIABILITY" lines (every writer its readers matched, GUID as on the wire).

Each dropped datagram is parsed as RTPS (OMG DDSI-RTPS 2.3, 8.3): the header's GUID prefix
(or the last INFO_SRC's) and each DATA / DATA_FRAG submessage's writerId name the writer; the
recorder's lines name the writer's topic. A DATA submessage is one sample (a DATA_FRAG a
fragment of one). Submessages protected by DDS Security (SEC_PREFIX ... SEC_POSTFIX: topics
whose metadata protection is SIGN or ENCRYPT) hide their writer and are counted apart.

With best-effort writers nothing is repaired: for a topic whose submessages are in clear,
the DATA submessages dropped on the recorder's link should be exactly the samples the
recorder reports missing. The script prints both per topic and the difference; it asserts
nothing (a benchmark's witness, not a test). A difference of -1 per stream can be a lost
last sample: the recorder counts holes between the ticks it received, and a stream's last
sample lost leaves no hole (compare the streams' last ticks in the recording). Topics whose
metadata are protected show no DATA in clear ("n/a"): their samples' datagrams are among the
"protected submessages only" ones, not attributable to a writer from the wire. On a legs
host's input (the `loss` scenario) the dropped DATA belong to writers the recorder does not
match (the per-leg partitions' writers), listed by entity id; each dropped sensor sample is a
tick the leg could not answer, i.e. a ValveCommand the recorder misses.
"""
import argparse
import re
import struct
import sys
from collections import Counter, defaultdict

LINKTYPE_NFLOG = 239
NFULA_PAYLOAD = 9
SUB_NAMES = {0x01: "PAD", 0x06: "ACKNACK", 0x07: "HEARTBEAT", 0x08: "GAP", 0x09: "INFO_TS",
             0x0c: "INFO_SRC", 0x0d: "INFO_REPLY_IP4", 0x0e: "INFO_DST", 0x0f: "INFO_REPLY",
             0x12: "NACK_FRAG", 0x13: "HEARTBEAT_FRAG", 0x15: "DATA", 0x16: "DATA_FRAG",
             0x30: "SEC_BODY", 0x31: "SEC_PREFIX", 0x32: "SEC_POSTFIX", 0x33: "SRTPS_PREFIX",
             0x34: "SRTPS_POSTFIX"}


def pcap_packets(path):
    """Yields the link-layer bytes of each record of a classic pcap file."""
    with open(path, "rb") as f:
        head = f.read(24)
        if len(head) < 24:
            raise SystemExit(f"{path}: not a pcap file (only {len(head)} bytes)")
        magic = head[:4]
        if magic in (b"\xd4\xc3\xb2\xa1", b"\x4d\x3c\xb2\xa1"):
            endian = "<"
        elif magic in (b"\xa1\xb2\xc3\xd4", b"\xa1\xb2\x3c\x4d"):
            endian = ">"
        else:
            raise SystemExit(f"{path}: not a pcap file (magic {magic.hex()}; pcapng is not read)")
        linktype = struct.unpack(endian + "I", head[20:24])[0]
        if linktype != LINKTYPE_NFLOG:
            raise SystemExit(f"{path}: link type {linktype}, expected NFLOG ({LINKTYPE_NFLOG})")
        while True:
            rec = f.read(16)
            if len(rec) < 16:
                return
            incl = struct.unpack(endian + "IIII", rec)[2]
            yield f.read(incl)


def nflog_payload(frame):
    """The network-layer packet inside an NFLOG frame (its TLVs are in host byte order)."""
    off = 4  # family, version, resource id
    while off + 4 <= len(frame):
        length, tlv_type = struct.unpack("<HH", frame[off:off + 4])
        if length < 4:
            return None
        if tlv_type == NFULA_PAYLOAD:
            return frame[off + 4:off + length]
        off += (length + 3) & ~3
    return None


def udp_payload(ip):
    if not ip or len(ip) < 20 or ip[0] >> 4 != 4 or ip[9] != 17:
        return None  # IPv4 + UDP only (the lab's subnet)
    if struct.unpack(">H", ip[6:8])[0] & 0x1fff:
        return None  # a later fragment of a datagram: no UDP header
    ihl = (ip[0] & 0x0f) * 4
    return ip[ihl + 8:]


def rtps_submessages(msg):
    """Yields (id, writer GUID hex or None) for each submessage of an RTPS message."""
    if len(msg) < 20 or msg[:4] != b"RTPS":
        return
    prefix = msg[8:20]
    off = 20
    while off + 4 <= len(msg):
        sid, flags = msg[off], msg[off + 1]
        e = "<" if flags & 1 else ">"
        length = struct.unpack(e + "H", msg[off + 2:off + 4])[0]
        body = msg[off + 4:] if length == 0 else msg[off + 4:off + 4 + length]
        writer = None
        if sid == 0x0c and len(body) >= 20:  # INFO_SRC: a new source GUID prefix
            prefix = body[8:20]
        elif sid in (0x15, 0x16) and len(body) >= 12:  # DATA, DATA_FRAG: writerId at 8..12
            writer = (prefix + body[8:12]).hex()
        yield sid, writer
        if length == 0:
            return
        off += 4 + length


def recorder_summary(log_text):
    """Per topic (received, missing) and the matched writers from the recorder's stop output."""
    missing = {}
    for m in re.finditer(r"^(hexa_\w+) +([0-9]+) +([0-9-]+) +([0-9-]+) +([0-9]+)", log_text, re.M):
        missing[m.group(1)] = (int(m.group(2)), None if m.group(3) == "-" else int(m.group(3)))
    writers = {}  # GUID -> (topic, reliability, ownership strength or None)
    for m in re.finditer(r"^matched writer (\S+) ([0-9a-f]{32}) (\S+)(?: strength (-?[0-9]+))?$", log_text, re.M):
        writers[m.group(2)] = (m.group(1), m.group(3), None if m.group(4) is None else int(m.group(4)))
    return missing, writers


def attribute(frames, writers):
    """Counts what the dropped datagrams (NFLOG frames) carried. `writers`: GUID -> (topic,
    reliability, strength) from recorder_summary. Returns a dict: packets, kinds (Counter of
    what each datagram carried), data / frag (Counter per row: topic, or topic + standby),
    submessages (Counter per submessage name), unknown (Counter per entity id)."""
    # Under exclusive ownership (ValveCommand with hot standbys) the writers of lower strength
    # are the standbys: their samples are not recorded while the primary lives, so their row
    # has no "rec missing" (the recorder's count is the primaries' row).
    top_strength = {}
    for topic, _, strength in writers.values():
        if strength is not None and (topic not in top_strength or strength > top_strength[topic]):
            top_strength[topic] = strength

    def row_of(w):
        topic, _, strength = w
        if strength is None or strength == top_strength.get(topic):
            return topic
        return f"{topic} (standby, strength {strength})"

    r = {"packets": 0, "kinds": Counter(), "data": Counter(), "frag": Counter(),
         "submessages": Counter(), "unknown": Counter(), "row_of": row_of}
    for frame in frames:
        r["packets"] += 1
        rtps = udp_payload(nflog_payload(frame))
        if rtps is None or rtps[:4] != b"RTPS":
            # A non-first IP fragment has no UDP header (large discovery / handshake messages).
            r["kinds"]["not RTPS (or a later IP fragment)"] += 1
            continue
        subs = list(rtps_submessages(rtps))
        recorded_data = False
        for sid, writer in subs:
            r["submessages"][SUB_NAMES.get(sid, f"0x{sid:02x}")] += 1
            if writer is None:
                continue
            if writer in writers:
                recorded_data = True
                r["data" if sid == 0x15 else "frag"][row_of(writers[writer])] += 1
            else:
                r["unknown"][writer[24:]] += 1  # entity id: builtin kinds are 0xc2 / 0xc3
        if recorded_data:
            r["kinds"]["DATA of a recorded writer"] += 1
        elif any(sid == 0x31 for sid, _ in subs):
            r["kinds"]["protected submessages only (SEC_PREFIX)"] += 1
        elif any(w is not None for _, w in subs):
            r["kinds"]["DATA of other writers only (discovery, builtin)"] += 1
        else:
            r["kinds"]["no DATA (heartbeats, acknacks, gaps, ...)"] += 1
    return r


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pcap", required=True, help="dropped.pcap written by --capture-drops")
    ap.add_argument("--recorder-log", required=True, help="the recorder's log (its stop summary)")
    a = ap.parse_args()
    missing, writers = recorder_summary(open(a.recorder_log, errors="replace").read())
    if not writers:
        raise SystemExit(f"{a.recorder_log}: no 'matched writer' lines (a recorder older than this "
                         "script, or it did not stop cleanly)")
    r = attribute(pcap_packets(a.pcap), writers)
    packets, kinds, submessages = r["packets"], r["kinds"], r["submessages"]
    data_by_topic, frag_by_topic, unknown_writers, row_of = r["data"], r["frag"], r["unknown"], r["row_of"]

    print(f"dropped datagrams captured: {packets}")
    for k, n in kinds.most_common():
        print(f"  {k}: {n}")
    print("submessages in them: " + ", ".join(f"{k} {n}" for k, n in submessages.most_common()))
    if unknown_writers:
        print("DATA of writers the recorder did not match (entity id: count): " +
              ", ".join(f"{k} {n}" for k, n in unknown_writers.most_common(8)))
        # User writers (entity kind 0x02 / 0x03; builtin ones are 0xc2 / 0xc3): on a legs host's
        # input, the plant's per-leg LegSensors and the supervisor's per-leg setpoints, which
        # write in the legs' partitions the recorder does not read.
        user = sum(n for k, n in unknown_writers.items() if k[-2:] in ("02", "03"))
        print(f"  of them user writers: {user} DATA in "
              f"{sum(1 for k in unknown_writers if k[-2:] in ('02', '03'))} writer(s)")
    reliability = defaultdict(set)
    for w in writers.values():
        reliability[row_of(w)].add(w[1])
    print(f"{'topic':40} {'writers':>7} {'reliability':>12} {'dropped DATA':>12} {'DATA_FRAG':>9} "
          f"{'rec missing':>11} {'difference':>10}")
    for topic in sorted(set(row_of(w) for w in writers.values()) | set(missing)):
        n_writers = sum(1 for w in writers.values() if row_of(w) == topic)
        rec = missing.get(topic, (0, None))[1]
        dropped = data_by_topic[topic]
        diff = "-" if rec is None else str(rec - dropped)
        if rec and dropped == 0 and frag_by_topic[topic] == 0:
            # None of its DATA in clear: protected metadata (SEC_PREFIX), or its samples do not
            # cross this link (a legs host's input: the missing commands were never written).
            diff = "n/a"
        print(f"{topic:40} {n_writers:7d} {'/'.join(sorted(reliability[topic])) or '-':>12} {dropped:12d} "
              f"{frag_by_topic[topic]:9d} {'-' if rec is None else rec:>11} {diff:>10}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
