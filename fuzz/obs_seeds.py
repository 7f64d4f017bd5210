#!/usr/bin/env python3
"""Write the heads of real RINEX observation files as rinex_obs fuzz seeds.

Usage: obs_seeds.py OUT_DIR FILE...

Each seed is the header and the first epochs of one file, cut at a line end to stay under
LIMIT bytes (the fuzz inputs' 64 KiB): RINEX 2 and 3 as they are, Hatanaka files (`.crx`,
`.??d`) decompressed from gzip first, and of every file also a gzip of its head, so that the
target's gzip path starts from real content. Named shared-<file>[.gz].
"""
import gzip
import os
import sys

LIMIT = 60000


def head(data):
    """The bytes of data up to the last line end before LIMIT."""
    if len(data) <= LIMIT:
        return data
    cut = data.rfind(b"\n", 0, LIMIT)
    return data[: cut + 1] if cut > 0 else data[:LIMIT]


def main():
    out = sys.argv[1]
    for path in sys.argv[2:]:
        name = os.path.basename(path)
        with open(path, "rb") as f:
            data = f.read(4 * LIMIT) if not path.endswith(".gz") else gzip.open(path).read(4 * LIMIT)
        if name.endswith(".gz"):
            name = name[:-3]
        h = head(data)
        with open(os.path.join(out, "shared-" + name), "wb") as f:
            f.write(h)
        # mtime 0: the same bytes on every run
        with open(os.path.join(out, "shared-" + name + ".gz"), "wb") as f:
            f.write(gzip.compress(h, mtime=0))


if __name__ == "__main__":
    main()
