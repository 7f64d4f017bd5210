#!/usr/bin/env python3
"""Write project_toml fuzz seeds: every field of a project file given a value of every TOML
kind, each section as a positional array, and the forms of `output` (a projection).

Usage: project_seeds.py OUT_DIR

serde's derived code has a branch for each field and each kind of value that can stand there
(a string where a number belongs, a date where a table belongs, an array one element short).
Mutation finds these a few at a time, so this script writes all of them:

- seq-SECTION-lenN.toml: a section (`[[camera]]`, `[images]`, `[ground]`, `[gnss]`,
  `[attitude]`, `[adjustment]`) as a positional array, serde filling the struct in field
  order, cut after each length (the fields after the cut take their defaults, or a required
  one is missing);
- seq-SECTION-kK-J.toml: the full array with element K of kind J (KINDS);
- tab-SECTION-FIELD-J.toml: the section as a table that loads (see `loading`) with FIELD of
  kind J; for a field that
  holds an array, arr-SECTION-FIELD-*.toml give it each length and an element of each kind;
  for a field that names a choice, enum-SECTION-FIELD-*.toml give each choice as a string
  and as a one-key table;
- omit-SECTION-FIELD.toml and only-SECTION-FIELD.toml: the section without FIELD, and with
  only FIELD beside the fields it needs to load (NEEDED; FIELD in place of its partner of
  PARTNERS);
- top-KEY-J.toml: a key of the document (`name`, `mode`, `output`, or a whole section) of
  kind J;
- output-K.toml: each of OUTPUTS, valid and not, for the number parsers of `Projection`.

A seed with the text of one before it is not written again.

Valid `[[camera]]` and `[images]` tables follow the section a seed varies, so a section that
deserialises goes on to load.
"""
import os
import sys

# Every field of each section in declaration order, with a value of its type.
SECTIONS = {
    "camera": [("id", '"demo"'), ("focal_mm", "35.0"), ("focal_px", "8974.0"),
               ("pixel_um", "3.9"), ("width_px", "4000"), ("height_px", "6000"),
               ("principal_point_mm", "[0.01, -0.02]"),
               ("principal_point_px", "[2000.5, 3000.5]"),
               ("distortion_centre_mm", "[0.02, 0.01]"),
               ("distortion_centre_px", "[2001.0, 2999.0]"), ("k", "[1e-5, -2e-9, 0.0]"),
               ("p", "[1e-7, -1e-7]"), ("b", "[1e-5, 0.0]"), ("sigma_px", "0.7"),
               ("self_calibrate", '["all"]'), ("fixed", '["k3", "b2"]')],
    "images": [("list", '"images.csv"'), ("measurements", '"image_observations.csv"'),
               ("patb", '"image_observations.im"'), ("start", '"start.csv"'),
               ("kappa_deg", "90.0")],
    "ground": [("file", '"ground_points.csv"'), ("crs", '"utm:32N"'), ("as_check", '["G1"]'),
               ("distances", '"distances.csv"')],
    "gnss": [("antennas", '"antennas.csv"'), ("trajectory", '"trajectory.pos"'),
             ("sigma_scale", "1.5"), ("lever_arm", "[0.1, -0.05, 0.45]"),
             ("lever_arm_sigma", "[0.005, 0.005, 0.01]"), ("estimate_lever_arm", "true"),
             ("drift", '"strip"'), ("drift_model", '"rate"'), ("latency", '"flight"'),
             ("latency_sigma", "0.01"), ("latency_start", "0.002"), ("coupling", '"loose"'),
             ("rover", '"rover.obs"'), ("base", '"base.obs"'), ("nav", '["nav.rnx"]'),
             ("base_position", "[4331297.3, 567555.6, 4633133.8]"), ("iono_ppm", "2.0")],
    "attitude": [("sigma_deg", "[0.05, 0.05, 0.2]"), ("boresight", "true"),
                 ("boresight_sigma_deg", "[1.0, 1.0, 1.0]")],
    "adjustment": [("max_iterations", "20"), ("snooping", "false"), ("alpha", "0.001"),
                   ("variance_components", "false"), ("loss", '"huber"')],
}

# The choices of each field that names one (serde enums).
CHOICES = {
    ("gnss", "drift"): ["auto", "none", "block", "strip", "segment"],
    ("gnss", "drift_model"): ["offset", "linear", "rate"],
    ("gnss", "latency"): ["none", "block", "flight"],
    ("gnss", "coupling"): ["loose", "tight"],
    ("top", "mode"): ["aerial", "close-range"],
}

# Pairs of fields of which a project may give one only (a camera's focal length, principal
# point and distortion centre in mm or px; measurements as CSV or PATB; antenna positions as a
# table or a trajectory).
PARTNERS = [("camera", "focal_mm", "focal_px"),
            ("camera", "principal_point_mm", "principal_point_px"),
            ("camera", "distortion_centre_mm", "distortion_centre_px"),
            ("images", "measurements", "patb"), ("gnss", "antennas", "trajectory")]


def partner(section, field):
    """The field `field` excludes, or None."""
    for s, a, b in PARTNERS:
        if s == section and field in (a, b):
            return b if field == a else a
    return None


# The fields a section needs to load (the first of each pair of PARTNERS where one is
# needed). Table seeds vary one field of a section that loads: every field of SECTIONS but
# the second of each pair, with the field varied in place of its partner.
NEEDED = {
    "camera": ["id", "focal_mm", "pixel_um", "width_px", "height_px"],
    "images": ["list", "measurements"],
    "ground": ["file"],
    "gnss": ["antennas"],
    "attitude": ["sigma_deg"],
    "adjustment": [],
}
SECOND = {(s, b) for s, _, b in PARTNERS}


def loading(section, field, value=None, keep=None):
    """The fields of a `section` that loads, with `field` in it (of `value`, when given) and
    its partner left out; `keep` (default: every field but the second of each pair) names
    the others."""
    if keep is None:
        keep = [name for name, _ in SECTIONS[section] if (section, name) not in SECOND]
    other = partner(section, field)
    fields = []
    for name, v in SECTIONS[section]:
        if name == field:
            fields.append((name, v if value is None else value))
        elif name != other and name in keep:
            fields.append((name, v))
    return fields


# A value of each kind TOML has, and the edges of the numeric ones.
KINDS = ['"x"', '""', "7", "-1", "0", "9223372036854775807", "7.5", "-0.0", "nan", "inf",
         "true", "1979-05-27T07:32:00Z", "1979-05-27T07:32:00", "1979-05-27", "07:32:00",
         "[]", "[1]", '["x"]', "[[1]]", "{}", "{ x = 1 }"]

# Top-level keys other than the sections.
TOP = ["name", "mode", "output"]

# Valid tables after the one a seed varies, so that a section that deserialises goes on to
# load (each but the one the seed gives).
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


def tail_after(section):
    """The valid tables that follow a seed varying `section`."""
    return {"camera": IMAGES, "images": CAMERA}.get(section, TAIL)


def as_array(section, values):
    """A document with `section` as a positional array of `values`."""
    array = "[" + ", ".join(values) + "]"
    if section == "camera":
        array = "[" + array + "]"
    return f'name = "{section} as an array"\n{section} = {array}\n{tail_after(section)}'


def as_table(section, fields):
    """A document with `section` as a table of `fields` (name, value)."""
    header = f"[[{section}]]" if section == "camera" else f"[{section}]"
    body = "\n".join(f"{k} = {v}" for k, v in fields)
    return f'name = "{section} as a table"\n{header}\n{body}\n{tail_after(section)}'


def array_forms(value):
    """An array field's value at each length from 0 to one past its own, and with its first
    and its last element of each kind."""
    items = [v.strip() for v in value.strip("[]").split(",")]
    forms = ["[" + ", ".join((items * 2)[:n]) + "]" for n in range(len(items) + 2)]
    for kind in KINDS:
        forms.append("[" + ", ".join([kind] + items[1:]) + "]")
        forms.append("[" + ", ".join(items[:-1] + [kind]) + "]")
    return forms


def choice_forms(choices):
    """A choice field's value as each choice, an unknown one, and each as a one-key table."""
    if not choices:
        return []
    forms = [f'"{c}"' for c in choices] + ['"unknown"', f'"{choices[0].upper()}"']
    for c in choices:
        forms += [f'{{ {c} = {{}} }}', f'{{ {c} = 1 }}', f'{{ "{c}" = "{c}" }}']
    return forms


def seeds():
    """Every seed as (file name, text)."""
    out = []
    for section, fields in SECTIONS.items():
        values = [v for _, v in fields]
        for n in range(len(values) + 1):
            out.append((f"seq-{section}-len{n}.toml", as_array(section, values[:n])))
        for k in range(len(values)):
            for j, kind in enumerate(KINDS):
                bad = values[:k] + [kind] + values[k + 1:]
                out.append((f"seq-{section}-k{k}-{j}.toml", as_array(section, bad)))
        for field, value in fields:
            families = [("tab", KINDS),
                        ("arr", array_forms(value) if value.startswith("[") else []),
                        ("enum", choice_forms(CHOICES.get((section, field), [])))]
            for prefix, forms in families:
                for j, form in enumerate(forms):
                    out.append((f"{prefix}-{section}-{field}-{j}.toml",
                                as_table(section, loading(section, field, form))))
            without = [f for f in loading(section, field) if f[0] != field]
            out.append((f"omit-{section}-{field}.toml", as_table(section, without)))
            out.append((f"only-{section}-{field}.toml",
                        as_table(section, loading(section, field, keep=NEEDED[section]))))
    for key in TOP + list(SECTIONS):
        forms = KINDS + choice_forms(CHOICES.get(("top", key), []))
        for j, form in enumerate(forms):
            out.append((f"top-{key}-{j}.toml", f"{key} = {form}\n{tail_after(key)}"))
    for k, o in enumerate(OUTPUTS):
        out.append((f"output-{k}.toml", f'name = "an output projection"\noutput = "{o}"\n{TAIL}'))
    return out


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    seen = set()
    for name, text in seeds():
        if text in seen:
            continue
        seen.add(text)
        with open(os.path.join(out, name), "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
