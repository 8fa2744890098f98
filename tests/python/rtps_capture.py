"""What crosses one network interface, as a packet capture sees it (an AF_PACKET socket: every
frame the interface sends or receives; needs root): UDP datagrams per destination port, and
the RTPS participants that sent them (the GUID prefix in each RTPS message's header, 12 bytes
after "RTPS", version and vendor). Usage: rtps_capture.py IFACE SECONDS. Prints READY once
capturing, then, after SECONDS or on SIGTERM, PORTS <json {port: count}> and PARTICIPANTS
<json [hex GUID prefix]>. IPv4 only (CycloneDDS's default); fragments after the first carry no
UDP header and are counted under port 0."""
import json
import signal
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
prefixes = set()
end = time.time() + seconds
stop = {"now": False}
signal.signal(signal.SIGTERM, lambda *_: stop.update(now=True))
while time.time() < end and not stop["now"]:
    try:
        frame = s.recv(65535)
    except (socket.timeout, InterruptedError):
        continue
    if len(frame) < 14 + 20 or struct.unpack("!H", frame[12:14])[0] != 0x0800:
        continue
    ip = frame[14:]
    if ip[9] != 17:  # UDP
        continue
    if struct.unpack("!H", ip[6:8])[0] & 0x1FFF:  # a later fragment: no UDP header
        counts[0] = counts.get(0, 0) + 1
        continue
    ihl = (ip[0] & 0x0F) * 4
    udp = ip[ihl:]
    if len(udp) < 8:
        continue
    dport = struct.unpack("!H", udp[2:4])[0]
    counts[dport] = counts.get(dport, 0) + 1
    rtps = udp[8:]
    if len(rtps) >= 20 and rtps[:4] == b"RTPS":
        prefixes.add(rtps[8:20].hex())
print("PORTS " + json.dumps(counts), flush=True)
print("PARTICIPANTS " + json.dumps(sorted(prefixes)), flush=True)
