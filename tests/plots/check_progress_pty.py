#!/usr/bin/python3
"""Progress lines on a terminal, captured through a pseudo-terminal: hexa_session shows the
session's progress (the recorder's simulated time) and then the report's, and
`hexa_recorder report` rewrites one line in place ("\\r\\033[K") with the fraction read, then
the plots' steps. Usage: check_progress_pty.py BUILD_DIR. Runs the default lockstep session (DDS on
loopback: run it inside a network namespace)."""
import os
import pty
import re
import select
import shutil
import subprocess
import sys
import tempfile

failures = []
ERASE = "\r\x1b[K"


def check(cond, what):
    print(("ok:   " if cond else "FAIL: ") + what)
    if not cond:
        failures.append(what)


def run_on_pty(cmd, timeout_s=600):
    """Runs cmd with stdout and stderr on a pseudo-terminal; returns (exit code, output)."""
    master, slave = pty.openpty()
    p = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=slave, stderr=slave, close_fds=True)
    os.close(slave)
    chunks = []
    while True:
        r, _, _ = select.select([master], [], [], timeout_s)
        if not r:
            p.kill()
            break
        try:
            data = os.read(master, 65536)
        except OSError:  # EIO: the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    return p.wait(), b"".join(chunks).decode("utf-8", "replace")


def redrawn_lines(out, prefix):
    """Texts drawn in place (after an erase) that start with prefix."""
    return [seg.split("\r")[0].split("\n")[0] for seg in out.split(ERASE)[1:] if seg.startswith(prefix)]


def main():
    build = sys.argv[1]
    out = tempfile.mkdtemp(prefix="progress_pty_")
    try:
        rc, text = run_on_pty([os.path.join(build, "deploy/hexa_session"), "--domain", "205",
                               "--out", os.path.join(out, "s"), "--timeout", "400"])
        check(rc == 0, f"session exit {rc}")
        session = redrawn_lines(text, "session: ")
        check(any(re.search(r"session: \d+ s, record: progress: [0-9.]+ s simulated", l) for l in session),
              f"hexa_session redraws 'session: N s, record: progress: T s simulated' ({session[-1:]})")
        report = redrawn_lines(text, "report: ")
        plotting = [l for l in report if "plot_session: [" in l]
        check(plotting and "report: done in" in text,
              f"then the report's: its plots' steps ({plotting[-1:]}), 'report: done in'")
        mcap = os.path.join(out, "s", "session.mcap")
        rc, text = run_on_pty([os.path.join(build, "services/recorder/hexa_recorder"), "report",
                               mcap, "--out", os.path.join(out, "r")])
        check(rc == 0, f"hexa_recorder report exit {rc}")
        reading = redrawn_lines(text, "report: reading session.mcap: ")
        check(any(re.search(r": +\d+ % after", l) for l in reading),
              f"report redraws 'report: reading session.mcap: NN % after ..' ({reading[:1]})")
        check(re.search(r"report: reading session.mcap: done in [0-9.]+ s\n", text.replace("\r\n", "\n"))
              is not None, "and ends it with 'done in'")
        plots = redrawn_lines(text, "plot_session: [")
        check(len(plots) == 6 and plots[-1].startswith("plot_session: [6/6]"),
              f"plot_session redraws one line per figure ({len(plots)}: {plots[-1:]})")
    finally:
        if not failures:
            shutil.rmtree(out, ignore_errors=True)
        else:
            print("outputs kept in", out)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
