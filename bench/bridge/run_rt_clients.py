#!/usr/bin/python3
"""Do Foxglove clients slow the real-time control loop? Real-time sessions side by side
(interleaved, same trajectory and seed), each with the bridge (hexa_session --bridge):

  clients      N clients reading every channel (tests/foxglove/js/load_clients.mjs, one node
               process) for the whole session
  no clients   the bridge alone, no client

Per session: completed (exit 0), late ticks (the plant's summary: commands applied a tick or
more late, % of all applied), schedule slips, control round trip (report.json), and what the
clients received. Every run is listed, then the totals per variant.

    /usr/bin/python3 bench/bridge/run_rt_clients.py --build build --runs 20 --clients 50
Run it in a private network namespace (unshare -n, or /work-style nsrun) on a quiet machine;
the load average is printed at the start and the end. Needs the test clients installed
(ctest -R foxglove.npm_install, or tests/foxglove/js/install.sh).
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

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
from run_bench import wait_port  # noqa: E402


def read_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def pin(cpus):
    """A preexec_fn that pins the child to CPUS ("0", "0,1"), or None for no pinning."""
    if not cpus:
        return None
    chosen = {int(c) for c in cpus.split(",")}
    return lambda: os.sched_setaffinity(0, chosen)


def run(a, variant, index, tmp):
    out = os.path.join(tmp, f"{variant.replace(' ', '_')}_{index}")
    argv = [os.path.join(a.build, "deploy/hexa_session"), "--trajectory", "combined",
            "--periods", str(a.periods), "--seed", str(a.seed), "--domain", str(a.domain),
            "--out", out, "--mode", "realtime", "--timeout", "600", "--bridge", "--bridge-port",
            "0", "--bridge-max-clients", str(max(32, a.clients))]
    session = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT,
                               start_new_session=True)
    load = None
    received = None
    try:
        if variant == "clients":
            try:
                port = wait_port(os.path.join(out, "bridge.log"), session)
            except RuntimeError:
                port = None
            if port is not None:
                load = subprocess.Popen(["node", "load_clients.mjs", f"ws://127.0.0.1:{port}",
                                         str(a.clients)], cwd=a.node_dir, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True,
                                        start_new_session=True, preexec_fn=pin(a.client_cpus))
        rc = session.wait()
    finally:
        if session.poll() is None:
            session.send_signal(signal.SIGINT)
            session.wait()
        if load is not None:
            load.send_signal(signal.SIGTERM)
            try:
                text = load.communicate(timeout=20)[0]
            except subprocess.TimeoutExpired:
                load.kill()
                text = load.communicate()[0]
            # The clients print their counts when the bridge closes their connections at the
            # session's end, or on the SIGTERM above if it came first.
            m = re.search(r"received (\d+)\.\.(\d+) messages per client", text)
            received = (int(m.group(1)), int(m.group(2))) if m else None
            if m is None:
                print(f"# {variant} run {index}: the clients printed no counts (exit "
                      f"{load.returncode}): {text.strip()[-300:]!r}", file=sys.stderr)
    r = {"variant": variant, "rc": rc, "completed": rc == 0, "received": received}
    summary = read_json(os.path.join(out, "plant.json"))
    if summary:
        legs = summary.get("legs", [])
        applied = sum(sum(l["command_age"]) for l in legs)
        late = sum(l["late_ticks"] for l in legs)
        r["late_pct"] = 100.0 * late / applied if applied else None
        r["slips"] = summary.get("schedule_slips")
    report = read_json(os.path.join(out, "report.json"))
    rt = (report or {}).get("control_round_trip_latency_s") or {}
    r["rt_median_us"] = rt["median"] * 1e6 if "median" in rt else None
    r["rt_p99_us"] = rt["p99"] * 1e6 if "p99" in rt else None
    return r


def fmt(v, spec):
    return "-" if v is None else format(v, spec)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--node-dir", help="where the test clients are installed (default: "
                    "BUILD/tests/foxglove/js)")
    ap.add_argument("--runs", type=int, default=20, help="sessions per variant")
    ap.add_argument("--clients", type=int, default=50)
    ap.add_argument("--periods", type=int, default=2)
    ap.add_argument("--seed", type=int, default=4)
    ap.add_argument("--domain", type=int, default=89)
    ap.add_argument("--client-cpus", default="",
                    help="pin the clients' node process to these CPUs (e.g. 0: the bridge's CPU, "
                         "standing for clients on another machine); default: not pinned")
    a = ap.parse_args()
    a.build = os.path.abspath(a.build)
    a.node_dir = os.path.abspath(a.node_dir or os.path.join(a.build, "tests/foxglove/js"))
    if not os.path.exists(os.path.join(a.node_dir, "node_modules", "@foxglove", "ws-protocol")):
        print(f"error: no test clients in {a.node_dir} (run tests/foxglove/js/install.sh)",
              file=sys.stderr)
        return 2
    tmp = tempfile.mkdtemp(prefix="bridge_rt_")
    print(f"# real time, combined x {a.periods} periods, seed {a.seed}, {a.runs} sessions per "
          f"variant interleaved, {a.clients} reading clients; outputs in {tmp}")
    print(f"# load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print("| run | variant | completed | late ticks % | slips | round trip median us | p99 us | "
          "received per client |")
    print("|---|---|---|---|---|---|---|---|")
    results = []
    for i in range(a.runs):
        for v in ("clients", "no clients"):
            r = run(a, v, i, tmp)
            results.append(r)
            got = "-" if r["received"] is None else f"{r['received'][0]}..{r['received'][1]}"
            print(f"| {i} | {v} | {'yes' if r['completed'] else 'no (exit %d)' % r['rc']} | "
                  f"{fmt(r.get('late_pct'), '.3f')} | {fmt(r.get('slips'), 'd')} | "
                  f"{fmt(r['rt_median_us'], '.0f')} | {fmt(r['rt_p99_us'], '.0f')} | {got} |",
                  flush=True)
    print()
    print("| variant | completed | late ticks % median (min-max) | slips total |")
    print("|---|---|---|---|")
    for v in ("clients", "no clients"):
        rr = [r for r in results if r["variant"] == v]
        late = [r["late_pct"] for r in rr if r.get("late_pct") is not None]
        slips = sum(r.get("slips") or 0 for r in rr)
        spread = (f"{statistics.median(late):.3f} ({min(late):.3f}-{max(late):.3f})"
                  if late else "-")
        print(f"| {v} | {sum(r['completed'] for r in rr)}/{len(rr)} | {spread} | {slips} |")
    print(f"# load average at end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
