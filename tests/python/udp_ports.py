"""Counts the UDP datagrams on one network interface by destination port, as a packet capture
would (an AF_PACKET socket: every frame the interface sends or receives; needs root). Usage:
udp_ports.py IFACE SECONDS. Prints READY once capturing, then PORTS <json {port: count}> after
SECONDS. Only IPv4 (CycloneDDS's default)."""
import json
import socket
import struct
import sys
import time

ETH_P_ALL = 0x0003
iface, seconds = sys.argv[1], float(sys.argv[2])
s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.ntohs(ETH_P_ALL))
s.bind((iface, 0))
s.settimeout(0.2)
print("READY", flush=True)
counts = {}
end = time.time() + seconds
while time.time() < end:
    try:
        frame = s.recv(65535)
    except socket.timeout:
        continue
    if len(frame) < 14 + 20 + 8 or struct.unpack("!H", frame[12:14])[0] != 0x0800:
        continue
    ihl = (frame[14] & 0x0F) * 4
    if frame[14 + 9] != 17:  # UDP
        continue
    dport = struct.unpack("!H", frame[14 + ihl + 2:14 + ihl + 4])[0]
    counts[dport] = counts.get(dport, 0) + 1
print("PORTS " + json.dumps(counts), flush=True)
