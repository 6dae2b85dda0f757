#!/usr/bin/python3
"""Reads a trace saved by lapse_trace.py (ftrace text, record-tgid) and answers where a leg's
milliseconds went (docs/measurements/deployment.md, "Where the lapses' milliseconds go").

  lapse_analyse.py gaps TRACE TID [T0 T1]     a thread's sends (net:netif_rx in its context)
                                              and every gap between them over 2 ms
  lapse_analyse.py cpu TRACE CPU T0 T1        who ran on CPU in [T0, T1]: run time per thread
                                              (with its kernel priority; lower runs first) and
                                              every uninterrupted run over 0.8 ms
  lapse_analyse.py softirq TRACE TID T0 T1    time the thread spent in softirqs, and the longest

TID is a thread id (the leg's `recvUC` from threads-<n>.txt); times are the trace's (clock
mono, seconds; the LAPSE_TRACE markers give wall and mono time of the fault line).
"""
import collections
import re
import sys

LINE = re.compile(r"^\s*(.+?)-(\d+)\s+\(\s*(\S+)\)\s+\[(\d+)\]\s+(\S+)\s+(\d+\.\d+):\s+(\w+):\s*(.*)$")
SWITCH = re.compile(r"prev_comm=(.*) prev_pid=(\d+) prev_prio=(\d+) prev_state=(\S+) ==> "
                    r"next_comm=(.*) next_pid=(\d+) next_prio=(\d+)")


def events(path, t0=float("-inf"), t1=float("inf")):
    """(comm, tid, tgid, cpu, t, event, detail) of the lines in [t0, t1]."""
    with open(path) as f:
        for line in f:
            m = LINE.match(line)
            if not m:
                continue
            t = float(m.group(6))
            if t < t0:
                continue
            if t > t1:
                break
            yield m.group(1), m.group(2), m.group(3), int(m.group(4)), t, m.group(7), m.group(8)


def gaps(path, tid, t0, t1):
    sends = [e[4] for e in events(path, t0, t1) if e[1] == tid and e[5] == "netif_rx"]
    for a, b in zip(sends, sends[1:]):
        if b - a > 0.002:
            print(f"gap {a:.6f} -> {b:.6f}: {(b - a) * 1e3:.2f} ms")
    if sends:
        print(f"{len(sends)} sends from {sends[0]:.6f} to {sends[-1]:.6f}; longest gap "
              f"{max((b - a for a, b in zip(sends, sends[1:])), default=0) * 1e3:.2f} ms")
    else:
        print("no sends of that thread in the window")


def cpu(path, cpu_no, t0, t1):
    cur = since = None
    total = collections.Counter()
    name = {}
    tgid = {}
    for comm, tid, tg, c, t, ev, detail in events(path, float("-inf"), t1):
        tgid[tid] = tg
        if c != cpu_no or ev != "sched_switch":
            continue
        s = SWITCH.search(detail)
        if not s:
            continue
        if cur is not None and t >= t0:
            a = max(since, t0)
            total[cur] += t - a
            if t - a > 0.0008:
                print(f"  run {name[cur]}-{cur} ({tgid.get(cur)}) {a:.6f}..{t:.6f}: "
                      f"{(t - a) * 1e3:.2f} ms, then {s.group(4)}")
        cur, since = s.group(6), t
        name[cur] = f"{s.group(5)}/prio{s.group(7)}"
    if cur is not None and since is not None:
        total[cur] += t1 - max(since, t0)
    for tid, v in total.most_common(15):
        print(f"{name[tid]:>30}-{tid} ({tgid.get(tid)}): {v * 1e3:.2f} ms")


def softirq(path, tid, t0, t1):
    entry = None
    spent = longest = 0.0
    n = 0
    for _, t_id, _, _, t, ev, _ in events(path, t0, t1):
        if t_id != tid:
            continue
        if ev == "softirq_entry":
            entry = t
        elif ev == "softirq_exit" and entry is not None:
            spent += t - entry
            longest = max(longest, t - entry)
            n += 1
            entry = None
    print(f"{tid}: {spent * 1e3:.2f} ms in {n} softirqs, the longest {longest * 1e3:.3f} ms")


def main(argv):
    if len(argv) < 4 or argv[1] not in ("gaps", "cpu", "softirq"):
        print(__doc__, file=sys.stderr)
        return 2
    what, path = argv[1], argv[2]
    if what == "gaps":
        t0 = float(argv[4]) if len(argv) > 4 else float("-inf")
        t1 = float(argv[5]) if len(argv) > 5 else float("inf")
        gaps(path, argv[3], t0, t1)
    elif what == "cpu":
        cpu(path, int(argv[3]), float(argv[4]), float(argv[5]))
    else:
        softirq(path, argv[3], float(argv[4]), float(argv[5]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
