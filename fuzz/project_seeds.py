#!/usr/bin/env python3
"""Write project_toml fuzz seeds: each section as a positional array, and the forms of
`output` (a projection).

Usage: project_seeds.py OUT_DIR

serde fills a struct from a TOML array in field order. For every section of a project file
(`[[camera]]`, `[images]`, `[ground]`, `[gnss]`, `[attitude]`, `[adjustment]`) this writes the
section as its full array cut after each length (seq-SECTION-lenN.toml: the fields after the
cut take their defaults, or a required one is missing) and as the full array with one element
of the wrong type (seq-SECTION-badK.toml). Each reaches a different branch of the section's
sequence visitor, which mutation finds only a few at a time. Valid `[[camera]]` and
`[images]` tables follow, so a section that deserialises goes on to load.

`output` names a projection by text with numbers in it (a UTM zone, a central meridian, an
EPSG code): output-K.toml gives each of OUTPUTS, valid and not, for the number parsers'
branches.
"""
import os
import sys

# Every field of each section in declaration order, with a value of its type.
SECTIONS = {
    "camera": ['"demo"', "35.0", "8974.0", "3.9", "4000", "6000", "[0.01, -0.02]",
               "[2000.5, 3000.5]", "[0.02, 0.01]", "[2001.0, 2999.0]", "[1e-5, -2e-9, 0.0]",
               "[1e-7, -1e-7]", "[1e-5, 0.0]", "0.7", '["all"]', '["k3", "b2"]'],
    "images": ['"images.csv"', '"image_observations.csv"', '"image_observations.im"',
               '"start.csv"', "90.0"],
    "ground": ['"ground_points.csv"', '"utm:32N"', '["G1"]', '"distances.csv"'],
    "gnss": ['"antennas.csv"', '"trajectory.pos"', "1.5", "[0.1, -0.05, 0.45]",
             "[0.005, 0.005, 0.01]", "true", '"strip"', '"rate"', '"flight"', "0.01", "0.002",
             '"loose"', '"rover.obs"', '"base.obs"', '["nav.rnx"]',
             "[4331297.3, 567555.6, 4633133.8]", "2.0"],
    "attitude": ["[0.05, 0.05, 0.2]", "true", "[1.0, 1.0, 1.0]"],
    "adjustment": ["20", "false", "0.001", "false", '"huber"'],
}

# Valid tables after the array, so that a section that deserialises goes on to load (each
# but the one the array gives).
CAMERA = """
[[camera]]
id = "demo"
focal_mm = 35.0
pixel_um = 3.9
width_px = 4000
height_px = 6000
"""
IMAGES = """
[images]
list = "images.csv"
measurements = "image_observations.csv"
"""
TAIL = CAMERA + IMAGES

OUTPUTS = ["geodetic", "utm", "utm:32N", "utm:32s", "utm:1", "utm:60", "utm:0", "utm:61",
           "utm:+7", "utm:-7", "utm:", "utm:N", "utm:999999999999", "gk:9", "gk:-3.5", "gk:+12",
           "gk:1e1", "gk:.5", "gk:5.", "gk:inf", "gk:NaN", "gk:-0", "gk:1_0", "gk:0x10", "gk:",
           "EPSG:25832", "epsg:32633", "EPSG:2056", "EPSG:4326", "EPSG:0", "EPSG:65535",
           "EPSG:65536", "EPSG:", "EPSG:+31467", "Epsg:3035", "UTM", "geodetic ", ""]


def wrong(value):
    """A value of another TOML type than `value`."""
    return '{ x = 1 }' if value.startswith('"') else '"x"'


def document(section, items):
    array = "[" + ", ".join(items) + "]"
    if section == "camera":
        array = "[" + array + "]"
    tail = {"camera": IMAGES, "images": CAMERA}.get(section, TAIL)
    return f'name = "{section} as an array"\n{section} = {array}\n{tail}'


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    for section, items in SECTIONS.items():
        for n in range(len(items) + 1):
            with open(os.path.join(out, f"seq-{section}-len{n}.toml"), "w") as f:
                f.write(document(section, items[:n]))
        for k, v in enumerate(items):
            bad = items[:k] + [wrong(v)] + items[k + 1:]
            with open(os.path.join(out, f"seq-{section}-bad{k}.toml"), "w") as f:
                f.write(document(section, bad))
    for k, o in enumerate(OUTPUTS):
        with open(os.path.join(out, f"output-{k}.toml"), "w") as f:
            f.write(f'name = "an output projection"\noutput = "{o}"\n{TAIL}')


if __name__ == "__main__":
    main()
