#!/usr/bin/python3
"""Security's cost on one machine, side by side in one run (docs/measurements/deployment.md).

N rounds; each round runs, one after the other:
  - hexa_session --trajectory z --periods 1 in lockstep, without and with --secure
    (the order alternates between rounds): lockstep speed (simulated s per wall s) and the
    control round trip (sensor written -> valve command written, report.json) median / p99;
  - ddsperf ping/pong over loopback (10 s at 1 kHz), without and with DDS Security
    (a CA and two identities made with deploy/make_security.sh): the raw round trip.
Prints every run and the medians, with the load average. Must run as root inside a private
network namespace (unshare -n), like every DDS benchmark here.

Usage: unshare -n sh -c 'ip link set lo up; /usr/bin/python3 bench/deployment/security_cost.py
       [--build build] [--runs 5] [--mode lockstep|realtime]'
"""
import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

GOVERNANCE = """<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules><domain_rule>
    <domains><id>{domain}</id></domains>
    <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
    <enable_join_access_control>true</enable_join_access_control>
    <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
    <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
    <rtps_protection_kind>NONE</rtps_protection_kind>
    <topic_access_rules><topic_rule>
      <topic_expression>*</topic_expression>
      <enable_discovery_protection>true</enable_discovery_protection>
      <enable_liveliness_protection>true</enable_liveliness_protection>
      <enable_read_access_control>true</enable_read_access_control>
      <enable_write_access_control>true</enable_write_access_control>
      <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
      <data_protection_kind>ENCRYPT</data_protection_kind>
    </topic_rule></topic_access_rules>
  </domain_rule></domain_access_rules>
</dds>
"""

PERMISSIONS = """<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions><grant name="{id}">
    <subject_name>CN={id},O=HexaTaar,OU=bench</subject_name>
    <validity><not_before>2020-01-01T00:00:00</not_before><not_after>2099-01-01T00:00:00</not_after></validity>
    <allow_rule><domains><id>{domain}</id></domains>
      <publish><topics><topic>*</topic></topics><partitions><partition>*</partition></partitions></publish>
      <subscribe><topics><topic>*</topic></topics><partitions><partition>*</partition></partitions></subscribe>
    </allow_rule>
    <default>DENY</default>
  </grant></permissions>
</dds>
"""

CONFIG = """<CycloneDDS xmlns="https://cdds.io/config"><Domain id="any"><General>
<Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces>
<AllowMulticast>spdp</AllowMulticast></General>
<Internal><HeartbeatInterval minsched="10 ms">10 ms</HeartbeatInterval></Internal>{security}</Domain></CycloneDDS>
"""

SECURITY = """<Security>
<Authentication><Library path="dds_security_auth" initFunction="init_authentication" finalizeFunction="finalize_authentication"/>
<IdentityCA>file:{sec}/ca_cert.pem</IdentityCA>
<IdentityCertificate>file:{sec}/${{HEXA_IDENTITY}}/cert.pem</IdentityCertificate>
<PrivateKey>file:{sec}/${{HEXA_IDENTITY}}/key.pem</PrivateKey></Authentication>
<AccessControl><Library path="dds_security_ac" initFunction="init_access_control" finalizeFunction="finalize_access_control"/>
<PermissionsCA>file:{sec}/ca_cert.pem</PermissionsCA>
<Governance>file:{sec}/governance.p7s</Governance>
<Permissions>file:{sec}/${{HEXA_IDENTITY}}/permissions.p7s</Permissions></AccessControl>
<Cryptographic><Library path="dds_security_crypto" initFunction="init_crypto" finalizeFunction="finalize_crypto"/></Cryptographic>
</Security>"""


def load():
    return open("/proc/loadavg").read().split()[:3]


def session(build, out, secure, mode, domain):
    cmd = [os.path.join(build, "deploy", "hexa_session"), "--trajectory", "z", "--periods", "1",
           "--mode", mode, "--out", out, "--domain", str(domain), "--timeout", "600"]
    if secure:
        cmd.append("--secure")
    rc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    path = os.path.join(out, "report.json")
    if rc != 0 or not os.path.exists(path):
        return None
    r = json.load(open(path))
    rtt = r["control_round_trip_latency_s"]
    # CPU of every process over its whole life (start-up and handshakes included) per
    # simulated second (hexa_session's processes.json).
    cpu = float("nan")
    procs_path = os.path.join(out, "processes.json")
    if os.path.exists(procs_path):
        procs = json.load(open(procs_path))
        if procs.get("sim_time_s", 0) > 0:
            cpu = (procs["cpu_user_s"] + procs["cpu_system_s"]) / procs["sim_time_s"]
    return {"speed": r["sim_time_s"] / r["wall_time_s"], "wall": r["wall_time_s"],
            "rtt_med_us": rtt["median"] * 1e6, "rtt_p99_us": rtt["p99"] * 1e6,
            "rmse_z_mm": r["rmse_vs_ground_truth"]["z_m"] * 1e3, "cpu": cpu}


def make_ddsperf_security(work, domain):
    src = os.path.join(work, "security-src")
    os.makedirs(os.path.join(src, "permissions"))
    open(os.path.join(src, "governance.xml"), "w").write(GOVERNANCE.format(domain=domain))
    with open(os.path.join(src, "identities.txt"), "w") as ids:
        for ident in ("ping", "pong"):
            open(os.path.join(src, "permissions", ident + ".xml"), "w").write(
                PERMISSIONS.format(id=ident, domain=domain))
            ids.write(f"{ident} local CN={ident},O=HexaTaar,OU=bench\n")
    subprocess.run([os.path.join(HERE, "deploy", "make_security.sh"), work], check=True,
                   stdout=subprocess.DEVNULL)
    sec = os.path.join(work, "hosts", "local", "etc", "hexa", "security")
    plain = os.path.join(work, "plain.xml")
    secured = os.path.join(work, "secure.xml")
    open(plain, "w").write(CONFIG.format(security=""))
    open(secured, "w").write(CONFIG.format(security=SECURITY.format(sec=sec)))
    return plain, secured


def ddsperf(config, domain, seconds=10):
    """Median and 99th percentile of ddsperf's one-way latency (half the round trip), us."""
    env = dict(os.environ, CYCLONEDDS_URI="file://" + config)
    pong = subprocess.Popen(["ddsperf", "-i", str(domain), "-D", str(seconds + 8), "pong", "waitset"],
                            env=dict(env, HEXA_IDENTITY="pong"), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    out = subprocess.run(["ddsperf", "-i", str(domain), "-D", str(seconds + 3), "ping", "1kHz", "waitset"],
                         env=dict(env, HEXA_IDENTITY="ping"), capture_output=True, text=True).stdout
    pong.terminate()
    pong.wait()
    meds, p99s = [], []
    for line in out.splitlines():
        m = re.search(r" 50% ([0-9.]+)us .* 99% ([0-9.]+)us", line)
        if m:
            meds.append(float(m.group(1)))
            p99s.append(float(m.group(2)))
    if len(meds) < 3:
        return None
    meds, p99s = meds[2:], p99s[2:]  # the first seconds include discovery / handshakes
    return {"rtt_med_us": 2 * statistics.median(meds), "rtt_p99_us": 2 * statistics.median(p99s)}


def median(rows, key):
    vals = [r[key] for r in rows if r is not None]
    return statistics.median(vals) if vals else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(HERE, "build"))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--mode", choices=["lockstep", "realtime"], default="lockstep")
    ap.add_argument("--no-ddsperf", action="store_true")
    a = ap.parse_args()
    if subprocess.run(["ip", "link", "show", "eth0"], capture_output=True).returncode == 0:
        sys.exit("security_cost: eth0 is visible: run inside `unshare -n` (private network namespace)")
    domain = 120 + os.getpid() % 60
    work = tempfile.mkdtemp(prefix="hexa_seccost_")
    plain_cfg, secure_cfg = make_ddsperf_security(work, domain)
    rows = {False: [], True: []}
    perf = {False: [], True: []}
    print(f"security cost, {a.runs} rounds, {a.mode}, z trajectory 1 period; load at start {' '.join(load())}")
    for k in range(a.runs):
        order = [False, True] if k % 2 == 0 else [True, False]
        for secure in order:
            r = session(a.build, os.path.join(work, f"s{k}{int(secure)}"), secure, a.mode, domain)
            rows[secure].append(r)
            tag = "secure" if secure else "plain "
            if r is None:
                print(f"round {k} {tag}: session FAILED (load {' '.join(load())})")
            else:
                print(f"round {k} {tag}: {r['speed']:.3f}x real time ({r['wall']:.1f} s wall), round trip "
                      f"median {r['rtt_med_us']:.0f} us p99 {r['rtt_p99_us']:.0f} us, RMSE z "
                      f"{r['rmse_z_mm']:.4f} mm, CPU {r['cpu']:.3f} s per sim s (load {' '.join(load())})")
            sys.stdout.flush()
        if not a.no_ddsperf:
            for secure in order:
                p = ddsperf(secure_cfg if secure else plain_cfg, domain)
                perf[secure].append(p)
                tag = "secure" if secure else "plain "
                if p:
                    print(f"round {k} {tag} ddsperf ping/pong 1 kHz: round trip median {p['rtt_med_us']:.0f} us "
                          f"p99 {p['rtt_p99_us']:.0f} us")
                else:
                    print(f"round {k} {tag} ddsperf: no result")
                sys.stdout.flush()
    print("\n| | without security | with DDS Security | ratio |")
    print("|---|---|---|---|")
    for key, label in (("speed", f"{a.mode} speed (sim s / wall s)"), ("rtt_med_us", "control round trip median (us)"),
                       ("rtt_p99_us", "control round trip p99 (us)"),
                       ("cpu", "CPU of all processes per sim s (whole life)")):
        p, s = median(rows[False], key), median(rows[True], key)
        print(f"| {label} | {p:.3f} | {s:.3f} | {s / p:.2f} |")
    if not a.no_ddsperf:
        for key, label in (("rtt_med_us", "ddsperf round trip median (us)"), ("rtt_p99_us", "ddsperf round trip p99 (us)")):
            p, s = median(perf[False], key), median(perf[True], key)
            print(f"| {label} | {p:.0f} | {s:.0f} | {s / p:.2f} |")
    done = {k: sum(r is not None for r in v) for k, v in rows.items()}
    print(f"\nsessions completed: plain {done[False]}/{a.runs}, secure {done[True]}/{a.runs}; "
          f"medians over the completed runs; load at end {' '.join(load())}; the machine was shared")
    if all(r is not None for v in rows.values() for r in v):
        shutil.rmtree(work, ignore_errors=True)
    else:
        print(f"logs of the failed sessions kept in {work}")


if __name__ == "__main__":
    main()
