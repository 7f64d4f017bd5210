#!/usr/bin/env python3
"""Write the heads of real RINEX observation files as rinex_obs fuzz seeds.

Usage: obs_seeds.py OUT_DIR FILE...

Each seed is the header and the first epochs of one file, cut at a line end to stay under
LIMIT bytes (far below the fuzz inputs' 64 KiB: libFuzzer's mutants take the size of the
inputs they come from, and heads of 60 KB made the target ten times slower, 170 inputs a
second against the 2,000 of small ones): RINEX 2 and 3 as they are, Hatanaka files (`.crx`,
`.??d`) decompressed from gzip first, and of every file also a gzip of its head, so that the
target's gzip path starts from real content. Named shared-<file>[.gz]. A Hatanaka head is
given twice LIMIT: its header and first epoch fill LIMIT, and the epochs after the first are
the ones it codes as differences.
"""
import gzip
import os
import sys

LIMIT = 8000


def head(data, limit):
    """The bytes of data up to the last line end before limit."""
    if len(data) <= limit:
        return data
    cut = data.rfind(b"\n", 0, limit)
    return data[: cut + 1] if cut > 0 else data[:limit]


def main():
    out = sys.argv[1]
    for path in sys.argv[2:]:
        name = os.path.basename(path)
        with (gzip.open if path.endswith(".gz") else open)(path, "rb") as f:
            data = f.read(4 * LIMIT)
        if name.endswith(".gz"):
            name = name[:-3]
        h = head(data, 2 * LIMIT if data.startswith(b"1.0 ") or data.startswith(b"3.0 ") else LIMIT)
        with open(os.path.join(out, "shared-" + name), "wb") as f:
            f.write(h)
        # mtime 0: the same bytes on every run
        with open(os.path.join(out, "shared-" + name + ".gz"), "wb") as f:
            f.write(gzip.compress(h, mtime=0))


if __name__ == "__main__":
    main()
