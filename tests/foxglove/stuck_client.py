#!/usr/bin/python3
"""A Foxglove WebSocket client that never reads: connects with a tiny receive buffer, reads the
handshake, serverInfo and advertise, subscribes to every channel, then never reads again (until
killed). hexa_bridge must drop this client's messages and count them, without slowing anything
else. Standard library only.
  /usr/bin/python3 stuck_client.py PORT
"""
import base64
import json
import os
import socket
import struct
import sys
import time


def send_text(sock, text):
    payload = text.encode()
    mask = os.urandom(4)
    head = bytes([0x81])
    n = len(payload)
    if n < 126:
        head += bytes([0x80 | n])
    elif n < 65536:
        head += bytes([0x80 | 126]) + struct.pack(">H", n)
    else:
        head += bytes([0x80 | 127]) + struct.pack(">Q", n)
    sock.sendall(head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))


def read_exact(sock, n):
    out = b""
    while len(out) < n:
        chunk = sock.recv(n - len(out))
        if not chunk:
            raise EOFError("connection closed")
        out += chunk
    return out


def read_frame(sock):
    b0, b1 = read_exact(sock, 2)
    n = b1 & 0x7F
    if n == 126:
        n = struct.unpack(">H", read_exact(sock, 2))[0]
    elif n == 127:
        n = struct.unpack(">Q", read_exact(sock, 8))[0]
    return b0 & 0x0F, read_exact(sock, n)


def connect(port, rcvbuf=None):
    """WebSocket handshake with the foxglove.websocket.v1 subprotocol; returns the socket."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if rcvbuf is not None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    sock.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                  f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                  "Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n").encode())
    head = b""
    while b"\r\n\r\n" not in head:
        head += read_exact(sock, 1)
    if b" 101 " not in head.split(b"\r\n")[0]:
        raise ConnectionError("handshake refused: " + head.split(b"\r\n")[0].decode())
    return sock


def main():
    port = int(sys.argv[1])
    sock = connect(port, rcvbuf=4096)
    channels = []
    while not channels:
        op, payload = read_frame(sock)
        if op == 1:
            msg = json.loads(payload)
            if msg.get("op") == "advertise":
                channels = [c["id"] for c in msg["channels"]]
    send_text(sock, json.dumps({"op": "subscribe",
                                "subscriptions": [{"id": i, "channelId": c} for i, c in enumerate(channels)]}))
    print(f"stuck_client: subscribed to {len(channels)} channels; never reading again", flush=True)
    while True:
        time.sleep(3600)


if __name__ == "__main__":
    sys.exit(main())
