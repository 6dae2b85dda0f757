#!/usr/bin/python3
"""Unit tests of bench/deployment/dropped_datagrams.py on a synthetic capture: NFLOG frames
carrying RTPS messages built here byte by byte (DDSI-RTPS 2.3, 8.3), no session run."""
import os
import struct
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench", "deployment"))
import dropped_datagrams as dd  # noqa: E402

PLANT = bytes.fromhex("0110aaaa0000000100000001")   # GUID prefixes (12 bytes)
LEG1 = bytes.fromhex("0110bbbb0000000100000001")
LEG4_STANDBY = bytes.fromhex("0110cccc0000000100000001")
SENSORS = bytes.fromhex("00001203")                 # user writer entity ids (kind 0x03)
VALVE = bytes.fromhex("00000f03")
SPDP = bytes.fromhex("000100c2")                    # a builtin writer


def sub(sid, body, little=True):
    return struct.pack("<BBH" if little else ">BBH", sid, 1 if little else 0, len(body)) + body


def data(writer_id, sn, little=True):
    e = "<" if little else ">"
    body = struct.pack(e + "HH", 0, 16) + bytes(4) + writer_id + struct.pack(e + "iI", 0, sn) + bytes(8)
    return sub(0x15, body, little)


def rtps(prefix, *subs):
    return b"RTPS" + bytes([2, 3, 1, 16]) + prefix + b"".join(subs)


def frame(payload, frag_offset=0):
    udp = struct.pack(">HHHH", 7411, 7413, 8 + len(payload), 0) + payload
    ip = struct.pack(">BBHHHBBH4s4s", 0x45, 0, 20 + len(udp), 1, frag_offset, 64, 17, 0,
                     bytes([10, 15, 0, 2]), bytes([10, 15, 0, 5])) + udp
    tlv = struct.pack("<HH", 4 + len(ip), dd.NFULA_PAYLOAD) + ip
    tlv += bytes((4 - len(tlv) % 4) % 4)
    prefix_tlv = struct.pack("<HH", 8, 1) + bytes(4)   # another TLV before the payload
    return bytes([2, 0, 0, 15]) + prefix_tlv + tlv


def write_pcap(path, frames):
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xa1b2c3d4, 2, 4, 0, 0, 262144, dd.LINKTYPE_NFLOG))
        for fr in frames:
            f.write(struct.pack("<IIII", 0, 0, len(fr), len(fr)) + fr)


LOG = """hexa_LegSensors            74694       3   3  0  0  0
hexa_ValveCommand          74558       2   2  0  0  0
hexa_NodeStatus             1054       -   -  0  0  0
matched writer hexa_LegSensors %s best-effort
matched writer hexa_ValveCommand %s best-effort strength 20
matched writer hexa_ValveCommand %s best-effort strength 10
matched writer hexa_NodeStatus %s reliable
""" % ((PLANT + SENSORS).hex(), (LEG1 + VALVE).hex(), (LEG4_STANDBY + VALVE).hex(), (PLANT + bytes.fromhex("00000202")).hex())


class Attribute(unittest.TestCase):
    def setUp(self):
        self.missing, self.writers = dd.recorder_summary(LOG)
        frames = [
            # the plant's tick: INFO_TS then three LegSensors samples in one datagram
            frame(rtps(PLANT, sub(0x09, bytes(8)), data(SENSORS, 1), data(SENSORS, 2), data(SENSORS, 3))),
            # leg 1's command, big-endian submessages
            frame(rtps(LEG1, sub(0x09, bytes(8), little=False), data(VALVE, 7, little=False))),
            # INFO_SRC switches the source: the next DATA is leg 1's although the header says plant
            frame(rtps(PLANT, sub(0x0c, bytes(8) + LEG1), data(VALVE, 8))),
            # the standby's command (not recorded while the primary lives)
            frame(rtps(LEG4_STANDBY, data(VALVE, 3))),
            # protected metadata: SEC_PREFIX / SEC_BODY / SEC_POSTFIX
            frame(rtps(PLANT, sub(0x31, bytes(8)), sub(0x30, bytes(32)), sub(0x32, bytes(16)))),
            # discovery only, a heartbeat only, a later IP fragment
            frame(rtps(PLANT, data(SPDP, 1))),
            frame(rtps(PLANT, sub(0x07, bytes(28)))),
            frame(b"\x00" * 40, frag_offset=185),
        ]
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "dropped.pcap")
            write_pcap(path, frames)
            self.r = dd.attribute(dd.pcap_packets(path), self.writers)

    def test_the_recorders_summary_and_writers_are_read(self):
        self.assertEqual(self.missing["hexa_LegSensors"], (74694, 3))
        self.assertEqual(self.missing["hexa_NodeStatus"], (1054, None))
        self.assertEqual(self.writers[(LEG1 + VALVE).hex()], ("hexa_ValveCommand", "best-effort", 20))
        self.assertEqual(self.writers[(PLANT + SENSORS).hex()], ("hexa_LegSensors", "best-effort", None))

    def test_each_data_submessage_is_counted_for_its_writers_topic(self):
        self.assertEqual(self.r["packets"], 8)
        self.assertEqual(self.r["data"]["hexa_LegSensors"], 3)
        # big-endian and after INFO_SRC both attributed to leg 1's writer
        self.assertEqual(self.r["data"]["hexa_ValveCommand"], 2)
        self.assertEqual(self.r["data"]["hexa_ValveCommand (standby, strength 10)"], 1)
        self.assertEqual(self.r["unknown"], {"000100c2": 1})

    def test_each_datagram_is_classified_once(self):
        k = self.r["kinds"]
        self.assertEqual(k["DATA of a recorded writer"], 4)
        self.assertEqual(k["protected submessages only (SEC_PREFIX)"], 1)
        self.assertEqual(k["DATA of other writers only (discovery, builtin)"], 1)
        self.assertEqual(k["no DATA (heartbeats, acknacks, gaps, ...)"], 1)
        self.assertEqual(k["not RTPS (or a later IP fragment)"], 1)
        self.assertEqual(sum(k.values()), 8)
        self.assertEqual(self.r["submessages"]["SEC_BODY"], 1)


class Pcap(unittest.TestCase):
    def test_another_link_type_is_refused(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "eth.pcap")
            with open(path, "wb") as f:
                f.write(struct.pack("<IHHiIII", 0xa1b2c3d4, 2, 4, 0, 0, 262144, 1))
            with self.assertRaises(SystemExit) as e:
                list(dd.pcap_packets(path))
            self.assertIn("expected NFLOG", str(e.exception))


if __name__ == "__main__":
    unittest.main()
