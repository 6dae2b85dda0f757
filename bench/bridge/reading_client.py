#!/usr/bin/python3
"""A Foxglove WebSocket client that subscribes to every channel of hexa_bridge and reads as fast
as it can (the well-behaved viewer of bench/bridge/run_bench.py). Prints the count on SIGTERM.
Standard library only.   /usr/bin/python3 reading_client.py PORT
"""
import json
import os
import signal
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests", "foxglove"))
from stuck_client import connect, read_frame, send_text  # noqa: E402

count = 0


def done(*_):
    print(f"received {count} messages", flush=True)
    sys.exit(0)


def main():
    global count
    signal.signal(signal.SIGTERM, done)
    sock = connect(int(sys.argv[1]))
    subscribed = False
    while True:
        op, payload = read_frame(sock)
        if op == 1 and not subscribed:
            msg = json.loads(payload)
            if msg.get("op") == "advertise":
                send_text(sock, json.dumps({"op": "subscribe", "subscriptions": [
                    {"id": i, "channelId": c["id"]} for i, c in enumerate(msg["channels"])]}))
                subscribed = True
                print("subscribed", flush=True)
        elif op == 2:
            count += 1
        elif op == 8:
            done()


if __name__ == "__main__":
    main()
