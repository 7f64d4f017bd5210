#!/usr/bin/env python3
"""Write the GPS and Galileo RXM-SFRBX payloads of u-blox logs as ubx fuzz seeds.

Usage: sfrbx_seeds.py OUT_DIR LOG.ubx...

Each seed holds the first PER_SEED payloads of one satellite and signal, back to back, as
the ubx target's `sfrbx_payloads` reads them (a mutated frame rarely keeps its checksum, so
whole logs seldom reach the GPS and Galileo decoders). SATS satellites per system, in the
order they first appear; named sfrbx-payloads-g<gnssId>-s<sigId>-sv<svId>.
"""
import os
import sys

PER_SEED = 40
SATS = 4
SYSTEMS = (0, 2)  # GPS, Galileo


def frames(data):
    """(class, id, payload) of every UBX frame with a good checksum."""
    i = 0
    while True:
        i = data.find(b"\xb5\x62", i)
        if i < 0 or i + 8 > len(data):
            return
        n = data[i + 4] | data[i + 5] << 8
        end = i + 6 + n
        if end + 2 > len(data):
            return
        a = b = 0
        for x in data[i + 2:end]:
            a = (a + x) & 0xFF
            b = (b + a) & 0xFF
        if data[end] == a and data[end + 1] == b:
            yield data[i + 2], data[i + 3], data[i + 6:end]
            i = end + 2
        else:
            i += 2


def main():
    out, logs = sys.argv[1], sys.argv[2:]
    groups = {}
    for log in logs:
        with open(log, "rb") as f:
            data = f.read()
        for cls, mid, p in frames(data):
            if cls == 0x02 and mid == 0x13 and len(p) >= 8 and p[0] in SYSTEMS:
                groups.setdefault((p[0], p[2], p[1]), []).append(p)
    per_system = {}
    for (g, s, sv), ps in groups.items():
        if len(ps) < PER_SEED or per_system.get(g, 0) >= SATS:
            continue
        per_system[g] = per_system.get(g, 0) + 1
        name = os.path.join(out, f"sfrbx-payloads-g{g}-s{s}-sv{sv}")
        with open(name, "wb") as f:
            f.write(b"".join(ps[:PER_SEED]))


if __name__ == "__main__":
    main()
