#!/usr/bin/python3
"""Does a Foxglove client that never reads slow the control loop? Sessions side by side
(interleaved, same trajectory and seed), the control round trip (plant sensor sample ->
valve command of the same tick, from the recording: report.json control_round_trip_latency_s)
per variant:

  bridge+reader        hexa_session --bridge, one client reading every channel
  bridge+reader+stuck  the same plus a client that subscribes to every channel and never
                       reads (stuck_client.py): its messages are dropped and counted
  no bridge            for reference: what the bridge itself costs

Also: the stuck client's drop count and the reading client's received count (bridge.log).
    /usr/bin/python3 bench/bridge/run_bench.py --build build --reps 3 [--mode lockstep|realtime]
Run it in a private network namespace (unshare -n) like every DDS benchmark here; the machine
is shared, so the load average is printed and variants are interleaved.
"""
import argparse
import json
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def wait_port(log_path, session, timeout_s=60):
    t0 = time.time()
    while time.time() - t0 < timeout_s:
        try:
            m = re.search(r"on ws://127\.0\.0\.1:(\d+)", open(log_path).read())
            if m:
                return int(m.group(1))
        except FileNotFoundError:
            pass
        if session.poll() is not None:
            raise RuntimeError("session ended before the bridge served")
        time.sleep(0.05)
    raise RuntimeError("bridge did not start")


def run(a, variant, rep, tmp):
    out = os.path.join(tmp, f"{variant}_{rep}")
    argv = [os.path.join(a.build, "deploy/hexa_session"), "--trajectory", "combined",
            "--periods", str(a.periods), "--seed", "4", "--domain", str(a.domain), "--out", out,
            "--mode", a.mode]
    if variant != "no bridge":
        argv += ["--bridge", "--bridge-port", "0", "--bridge-queue-kb", str(a.queue_kb)]
    session = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT,
                               start_new_session=True)
    clients = []
    try:
        if variant != "no bridge":
            port = wait_port(os.path.join(out, "bridge.log"), session)
            clients.append(subprocess.Popen(
                ["/usr/bin/python3", os.path.join(HERE, "reading_client.py"), str(port)],
                stdout=open(os.path.join(out, "reader.out"), "w"), stderr=subprocess.STDOUT,
                start_new_session=True))
            reader_out = os.path.join(out, "reader.out")
            for _ in range(200):  # the reader is client 1, the stuck one client 2
                if "subscribed" in open(reader_out).read():
                    break
                time.sleep(0.05)
            if "stuck" in variant:
                clients.append(subprocess.Popen(
                    ["/usr/bin/python3", os.path.join(ROOT, "tests/foxglove/stuck_client.py"),
                     str(port)], stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT,
                    start_new_session=True))
        rc = session.wait(timeout=600)
    finally:
        for c in clients:
            if c.poll() is None:
                c.send_signal(signal.SIGTERM)
                c.wait()
        if session.poll() is None:
            session.send_signal(signal.SIGINT)
            session.wait()
    rep_json = json.load(open(os.path.join(out, "report.json")))
    rt = rep_json["control_round_trip_latency_s"]
    res = dict(rc=rc, median_us=rt["median"] * 1e6, p99_us=rt["p99"] * 1e6,
               max_us=rt["max"] * 1e6, wall_s=rep_json["wall_time_s"], dropped=None, read=None)
    if variant != "no bridge":
        log = open(os.path.join(out, "bridge.log")).read()
        drops = [int(x) for x in re.findall(r"client 2 \([^)]*\)[^\n]*dropped (\d+)", log)]
        res["dropped"] = max(drops) if drops else 0
        m = re.findall(r"received (\d+) messages", open(os.path.join(out, "reader.out")).read())
        res["read"] = int(m[-1]) if m else 0
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--periods", type=int, default=3)
    ap.add_argument("--domain", type=int, default=88)
    ap.add_argument("--mode", default="lockstep", choices=["lockstep", "realtime"])
    ap.add_argument("--queue-kb", type=int, default=1024, help="hexa_bridge --client-queue-kb")
    ap.add_argument("--variants", default="bridge+reader,bridge+reader+stuck,no bridge")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="bridge_bench_")
    variants = a.variants.split(",")
    print(f"# bridge benchmark: {a.mode}, combined x {a.periods} periods, {a.reps} reps per "
          f"variant, interleaved, client queue {a.queue_kb} KiB; outputs in {tmp}")
    print(f"# load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    results = {v: [] for v in variants}
    for rep in range(a.reps):
        for v in variants:
            r = run(a, v, rep, tmp)
            results[v].append(r)
            print(f"#   rep {rep} {v}: median {r['median_us']:.0f} us, p99 {r['p99_us']:.0f} us, "
                  f"wall {r['wall_s']:.1f} s, exit {r['rc']}, stuck dropped {r['dropped']}, "
                  f"reader received {r['read']}", flush=True)
    print("| variant | round trip median us (median of reps) | p99 us | max us | wall s | "
          "sessions completed | reading client received | stuck client dropped |")
    print("|---|---|---|---|---|---|---|---|")
    for v in variants:
        rr = results[v]
        med = lambda k: statistics.median(x[k] for x in rr)  # noqa: E731
        drop = "-" if rr[0]["dropped"] is None or "stuck" not in v else f"{med('dropped'):.0f}"
        read = "-" if rr[0]["read"] is None else f"{med('read'):.0f}"
        each = ", ".join(f"{x['median_us']:.0f}" for x in rr)
        print(f"| {v} | {med('median_us'):.0f} ({each}) | "
              f"{med('p99_us'):.0f} | {med('max_us'):.0f} | {med('wall_s'):.1f} | "
              f"{sum(x['rc'] == 0 for x in rr)}/{len(rr)} | {read} | {drop} |")
    print(f"# load average at end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
