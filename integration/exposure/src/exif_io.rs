//! EXIF of JPEG photographs, read and rewritten within bounds: a photo is a file from anywhere,
//! so its directory chains may loop and its counts may lie. Reading goes through
//! `kamadak-exif` (every offset and count checked against the bytes present, at most 8 IFDs
//! in a chain, child directories followed by kind, not by address, so no loop); rewriting
//! re-encodes the fields that were read, with the GPS directory replaced, and splices the new
//! APP1 segment into the JPEG by a bounded walk of its segments. Nothing here allocates more
//! than a small multiple of the file's size.
//!
//! Enters: a photo's path or bytes. Leaves: its EXIF fields, or why they cannot be read; the
//! bytes of a geotagged copy (EXIF GPS, and the XMP packet of [`super::xmp`] in its own APP1
//! segment). Used by [`super::photos`].

use super::xmp::{self, PositionTag, XMP_ID};
use exif::experimental::Writer;
use exif::{Exif, Field, In, Rational, Reader, Tag, Value};
use std::io::Cursor;
use std::path::Path;

/// Largest photo read whole for geotagging, bytes (a JPEG of 1 GiB is no photograph).
pub const MAX_PHOTO_BYTES: u64 = 1 << 30;

/// The EXIF of a photo: `Ok(None)` when it has none, `Err(reason)` when it cannot be read.
pub fn read(path: &Path) -> Result<Option<Exif>, String> {
    let file = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
    let mut r = std::io::BufReader::new(file);
    match Reader::new().read_from_container(&mut r) {
        Ok(x) => Ok(Some(x)),
        Err(exif::Error::NotFound(_)) => Ok(None),
        Err(e) => Err(format!("its EXIF cannot be read ({e})")),
    }
}

/// The first ASCII value of `tag` in the primary image, as text.
pub fn ascii(x: &Exif, tag: Tag) -> Option<String> {
    match &x.get_field(tag, In::PRIMARY)?.value {
        Value::Ascii(v) => v.first().map(|s| String::from_utf8_lossy(s).into_owned()),
        _ => None,
    }
}

/// Rationals of `tag` in the primary image as numbers (a zero denominator gives `None`).
pub fn rationals(x: &Exif, tag: Tag) -> Option<Vec<f64>> {
    match &x.get_field(tag, In::PRIMARY)?.value {
        Value::Rational(v) => v
            .iter()
            .map(|r| (r.denom != 0).then(|| r.num as f64 / r.denom as f64))
            .collect(),
        _ => None,
    }
}

/// Latitude, longitude (degrees) and height (m) of the photo's GPS directory; the height is
/// `None` when it has no GPSAltitude (ppkat's copies with ellipsoidal heights).
pub fn gps_position(x: &Exif) -> Option<(f64, f64, Option<f64>)> {
    let dms = |tag| {
        let v = rationals(x, tag)?;
        let d = v
            .iter()
            .zip([1.0, 60.0, 3600.0])
            .map(|(a, s)| a / s)
            .sum::<f64>();
        d.is_finite().then_some(d)
    };
    let sign = |tag, neg: char| match ascii(x, tag) {
        Some(r) if r.starts_with(neg) => -1.0,
        _ => 1.0,
    };
    let lat = dms(Tag::GPSLatitude)? * sign(Tag::GPSLatitudeRef, 'S');
    let lon = dms(Tag::GPSLongitude)? * sign(Tag::GPSLongitudeRef, 'W');
    let below = match &x
        .get_field(Tag::GPSAltitudeRef, In::PRIMARY)
        .map(|f| &f.value)
    {
        Some(Value::Byte(b)) => b.first() == Some(&1),
        _ => false,
    };
    let h = rationals(x, Tag::GPSAltitude)
        .and_then(|v| v.first().copied())
        .map(|h| if below { -h } else { h });
    Some((lat, lon, h))
}

fn rational(num: u32, denom: u32) -> Rational {
    Rational { num, denom }
}

/// Degrees as degrees, minutes, seconds (1/10000 s).
fn dms(v: f64) -> Value {
    let a = v.abs();
    let d = a.floor();
    let m = ((a - d) * 60.0).floor();
    let s = ((a - d) * 60.0 - m) * 60.0;
    Value::Rational(vec![
        rational(d as u32, 1),
        rational(m as u32, 1),
        rational((s * 10_000.0).round() as u32, 10_000),
    ])
}

/// The GPS fields of a position: WGS84 latitude, longitude (degrees) and, only when the height
/// is orthometric, GPSAltitude with GPSAltitudeRef (above or below sea level): EXIF has no
/// way to say "above the ellipsoid", so an ellipsoidal height goes to the XMP packet only.
fn gps_fields(tag: &PositionTag) -> Vec<Field> {
    let (lat, lon, h) = (tag.lat, tag.lon, tag.height);
    let f = |tag, value| Field {
        tag,
        ifd_num: In::PRIMARY,
        value,
    };
    let text = |s: &str| Value::Ascii(vec![s.as_bytes().to_vec()]);
    let mut out = vec![
        f(Tag::GPSVersionID, Value::Byte(vec![2, 3, 0, 0])),
        f(
            Tag::GPSLatitudeRef,
            text(if lat >= 0.0 { "N" } else { "S" }),
        ),
        f(Tag::GPSLatitude, dms(lat)),
        f(
            Tag::GPSLongitudeRef,
            text(if lon >= 0.0 { "E" } else { "W" }),
        ),
        f(Tag::GPSLongitude, dms(lon)),
        f(Tag::GPSMapDatum, text("WGS-84")),
    ];
    if tag.orthometric {
        out.push(f(Tag::GPSAltitudeRef, Value::Byte(vec![u8::from(h < 0.0)])));
        out.push(f(
            Tag::GPSAltitude,
            Value::Rational(vec![rational((h.abs() * 1000.0).round() as u32, 1000)]),
        ));
    }
    out
}

/// One segment of a JPEG before its image data: marker and the byte range of the whole
/// segment (marker included).
struct Segment {
    marker: u8,
    start: usize,
    end: usize,
}

/// The segments of a JPEG up to its image data, and where the image data starts. Every
/// length is checked against the bytes present; each step moves forward, so the walk ends.
fn segments(jpeg: &[u8]) -> Result<(Vec<Segment>, usize), String> {
    if !jpeg.starts_with(&[0xFF, 0xD8]) {
        let kind = if jpeg.starts_with(b"\x89PNG") {
            "a PNG image"
        } else if jpeg.starts_with(b"II*\0") || jpeg.starts_with(b"MM\0*") {
            "a TIFF image"
        } else {
            "not an image this program knows"
        };
        return Err(format!(
            "not a JPEG file ({kind}, whatever its name says): only JPEG photos can be geotagged"
        ));
    }
    let mut out = Vec::new();
    let mut at = 2;
    loop {
        let truncated = || format!("the JPEG is truncated or damaged at byte {at}");
        if at + 2 > jpeg.len() || jpeg[at] != 0xFF {
            return Err(truncated());
        }
        let marker = jpeg[at + 1];
        if marker == 0xDA || marker == 0xD9 {
            return Ok((out, at));
        }
        if marker == 0xFF {
            at += 1; // fill byte
            continue;
        }
        if marker == 0x01 || (0xD0..=0xD7).contains(&marker) {
            at += 2; // no length
            continue;
        }
        if at + 4 > jpeg.len() {
            return Err(truncated());
        }
        let len = u16::from_be_bytes([jpeg[at + 2], jpeg[at + 3]]) as usize;
        if len < 2 || at + 2 + len > jpeg.len() {
            return Err(truncated());
        }
        out.push(Segment {
            marker,
            start: at,
            end: at + 2 + len,
        });
        at += 2 + len;
    }
}

/// Whether a segment is an EXIF APP1.
fn is_exif(jpeg: &[u8], s: &Segment) -> bool {
    s.marker == 0xE1 && jpeg[s.start + 4..s.end].starts_with(b"Exif\0\0")
}

/// Whether a segment is an XMP APP1.
fn is_xmp(jpeg: &[u8], s: &Segment) -> bool {
    s.marker == 0xE1 && jpeg[s.start + 4..s.end].starts_with(XMP_ID)
}

/// The XMP packet of a JPEG, when it has one (as text; invalid UTF-8 replaced).
pub fn xmp_packet(jpeg: &[u8]) -> Option<String> {
    let (segs, _) = segments(jpeg).ok()?;
    let s = segs.iter().find(|s| is_xmp(jpeg, s))?;
    Some(String::from_utf8_lossy(&jpeg[s.start + 4 + XMP_ID.len()..s.end]).into_owned())
}

/// A copy of the JPEG `jpeg` whose EXIF and XMP carry the position of `tag`: the EXIF fields
/// the photo had are kept (the thumbnail too while it fits), its GPS directory replaced (an
/// altitude only for orthometric heights, see `gps_fields`); its XMP packet edited (or one
/// added) by [`xmp::packet`]. `Err` says why the photo cannot be tagged (not a JPEG, damaged,
/// EXIF unreadable, XMP too large); the input is never changed.
pub fn geotagged(jpeg: &[u8], tag: &PositionTag) -> Result<Vec<u8>, String> {
    let (segs, data) = segments(jpeg)?;
    let old = match segs.iter().find(|s| is_exif(jpeg, s)) {
        Some(s) => Some(
            Reader::new()
                .read_raw(jpeg[s.start + 10..s.end].to_vec())
                .map_err(|e| format!("its EXIF cannot be read ({e})"))?,
        ),
        None => None,
    };
    let gps = gps_fields(tag);
    let tiff = encode(old.as_ref(), &gps, true)
        .or_else(|_| encode(old.as_ref(), &gps, false))
        .map_err(|e| format!("its EXIF cannot be rewritten ({e})"))?;
    let mut app1 = Vec::with_capacity(tiff.len() + 10);
    app1.extend_from_slice(&[0xFF, 0xE1]);
    app1.extend_from_slice(&((tiff.len() + 8) as u16).to_be_bytes());
    app1.extend_from_slice(b"Exif\0\0");
    app1.extend_from_slice(&tiff);
    // After a leading JFIF APP0 (which must come first), else right after SOI.
    let after = match segs.first() {
        Some(s) if s.marker == 0xE0 => s.end,
        _ => 2,
    };
    let old_xmp = xmp_packet(jpeg);
    let packet = xmp::packet(old_xmp.as_deref(), tag);
    let len = 2 + XMP_ID.len() + packet.len();
    if len > u16::MAX as usize {
        return Err(format!(
            "its XMP packet would be {len} bytes, more than a JPEG segment holds"
        ));
    }
    let mut xmp_seg = vec![0xFF, 0xE1];
    xmp_seg.extend_from_slice(&(len as u16).to_be_bytes());
    xmp_seg.extend_from_slice(XMP_ID);
    xmp_seg.extend_from_slice(packet.as_bytes());
    let mut out = Vec::with_capacity(jpeg.len() + app1.len() + xmp_seg.len());
    out.extend_from_slice(&jpeg[..after]);
    out.extend_from_slice(&app1);
    out.extend_from_slice(&xmp_seg);
    for s in segs
        .iter()
        .filter(|s| s.start >= after && !is_exif(jpeg, s) && !is_xmp(jpeg, s))
    {
        out.extend_from_slice(&jpeg[s.start..s.end]);
    }
    out.extend_from_slice(&jpeg[data..]);
    Ok(out)
}

/// The TIFF structure of the fields of `old` (GPS fields and unknown types left out) plus
/// `gps`, with the thumbnail when `thumbnail`; `Err` when it would not fit an APP1 segment.
fn encode(old: Option<&Exif>, gps: &[Field], thumbnail: bool) -> Result<Vec<u8>, String> {
    let mut w = Writer::new();
    let thumb = old.and_then(|x| thumbnail_bytes(x)).filter(|_| thumbnail);
    let keep = |f: &&Field| {
        !matches!(f.tag.context(), exif::Context::Gps)
            && !matches!(f.value, Value::Unknown(..))
            && (f.ifd_num == In::PRIMARY || (f.ifd_num == In::THUMBNAIL && thumb.is_some()))
    };
    for f in old.into_iter().flat_map(|x| x.fields()).filter(keep) {
        w.push_field(f);
    }
    for f in gps {
        w.push_field(f);
    }
    if let Some(t) = thumb {
        w.set_jpeg(t, In::THUMBNAIL);
    }
    let mut buf = Cursor::new(Vec::new());
    let little = old.is_none_or(|x| x.little_endian());
    w.write(&mut buf, little).map_err(|e| e.to_string())?;
    let tiff = buf.into_inner();
    if tiff.len() + 8 > u16::MAX as usize {
        return Err(format!("{} bytes do not fit a JPEG segment", tiff.len()));
    }
    Ok(tiff)
}

/// The thumbnail JPEG of an EXIF, when its offset and length lie inside the data.
fn thumbnail_bytes(x: &Exif) -> Option<&[u8]> {
    let get = |tag| x.get_field(tag, In::THUMBNAIL)?.value.get_uint(0);
    let (at, len) = (
        get(Tag::JPEGInterchangeFormat)? as usize,
        get(Tag::JPEGInterchangeFormatLength)? as usize,
    );
    x.buf().get(at..at.checked_add(len)?)
}
