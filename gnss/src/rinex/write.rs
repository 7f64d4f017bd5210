//! RINEX 3.04 observation writer: header, observation epochs and flag-5 event records, in
//! the layout RTKLIB and the RINEX 3.04 standard use (F14.3 values, LLI and SSI digits).
//!
//! What enters: a [`HeaderOut`] and the records of [`super`] ([`SatObs`] aligned with
//! the header's types, NaN for blank). What leaves: text on a `Write`. Reading the text back
//! with [`super::ObsFile`] gives the same values to the printed precision.

use super::{ObsCode, SatObs};
use crate::sv::Constellation;
use hifitime::{Epoch, TimeScale};
use std::io::{Result, Write};

/// What the header of an observation file says.
#[derive(Clone, Debug)]
pub struct HeaderOut {
    /// Program that wrote the file (PGM / RUN BY / DATE).
    pub program: String,
    /// COMMENT lines.
    pub comments: Vec<String>,
    /// MARKER NAME.
    pub marker: String,
    /// APPROX POSITION XYZ, metres (zeros when unknown).
    pub approx: [f64; 3],
    /// ANTENNA: DELTA H, metres.
    pub delta_h: f64,
    /// REC # / TYPE / VERS: serial number, type, version.
    pub receiver: [String; 3],
    /// ANT # / TYPE: serial number, type.
    pub antenna: [String; 2],
    /// Observation types of each system, in this order.
    pub types: Vec<(Constellation, Vec<ObsCode>)>,
    /// TIME OF FIRST OBS and TIME OF LAST OBS (GPST).
    pub first: Epoch,
    /// See `first`.
    pub last: Epoch,
    /// GLONASS slots and frequency channels.
    pub glonass: Vec<(u8, i8)>,
}

/// `yyyy mm dd hh mm ss.sssssss` as RINEX 3 epoch lines have it (seconds F11.7), rounded to
/// 100 ns first so that 59.99999999 s does not print as 60.
pub fn epoch_fields(t: Epoch) -> String {
    let ns = t.to_gpst_nanoseconds().unwrap_or(0);
    let t = Epoch::from_gpst_nanoseconds((ns + 50) / 100 * 100);
    let (y, mo, d, h, mi, s, ns) = t.to_gregorian(TimeScale::GPST);
    format!(
        "{y:04} {mo:02} {d:02} {h:02} {mi:02}{:11.7}",
        s as f64 + ns as f64 * 1e-9
    )
}

/// One header line: `a` in columns 1–60, the label after.
pub(super) fn line(w: &mut dyn Write, a: &str, label: &str) -> Result<()> {
    writeln!(w, "{a:<60.60}{label}")
}

/// The first lines of a RINEX 3.04 header of file type `kind` (`"OBSERVATION DATA"`,
/// `"N: GNSS NAV DATA"`): version and type, program, comments.
pub(super) fn opening(
    w: &mut dyn Write,
    kind: &str,
    program: &str,
    comments: &[String],
) -> Result<()> {
    line(
        w,
        &format!("     3.04           {kind:<20}M: Mixed"),
        "RINEX VERSION / TYPE",
    )?;
    line(
        w,
        &format!("{program:<20}{:<20}", "ppkat"),
        "PGM / RUN BY / DATE",
    )?;
    for c in comments {
        line(w, c, "COMMENT")?;
    }
    Ok(())
}

/// Write the header.
pub fn write_header(w: &mut dyn Write, h: &HeaderOut) -> Result<()> {
    opening(w, "OBSERVATION DATA", &h.program, &h.comments)?;
    line(w, &h.marker, "MARKER NAME")?;
    line(w, "", "OBSERVER / AGENCY")?;
    let [rn, rt, rv] = &h.receiver;
    line(
        w,
        &format!("{rn:<20}{rt:<20}{rv:<20}"),
        "REC # / TYPE / VERS",
    )?;
    let [an, at] = &h.antenna;
    line(w, &format!("{an:<20}{at:<20}"), "ANT # / TYPE")?;
    let [x, y, z] = h.approx;
    line(
        w,
        &format!("{x:14.4}{y:14.4}{z:14.4}"),
        "APPROX POSITION XYZ",
    )?;
    line(
        w,
        &format!("{:14.4}{:14.4}{:14.4}", h.delta_h, 0.0, 0.0),
        "ANTENNA: DELTA H/E/N",
    )?;
    for (sys, types) in &h.types {
        for (k, chunk) in types.chunks(13).enumerate() {
            let mut s = if k == 0 {
                format!("{}  {:3}", sys.letter(), types.len())
            } else {
                "      ".to_string()
            };
            for t in chunk {
                s.push_str(&format!(" {t}"));
            }
            line(w, &s, "SYS / # / OBS TYPES")?;
        }
    }
    for (t, label) in [(h.first, "TIME OF FIRST OBS"), (h.last, "TIME OF LAST OBS")] {
        let f = epoch_fields(t);
        let p: Vec<&str> = f.split_whitespace().collect();
        let s = format!(
            "  {}    {}    {}    {}    {}   {:>10}     GPS",
            p[0], p[1], p[2], p[3], p[4], p[5]
        );
        line(w, &s, label)?;
    }
    for (sys, types) in &h.types {
        for t in types.iter().filter(|t| t.kind() == b'L') {
            line(w, &format!("{} {t}", sys.letter()), "SYS / PHASE SHIFT")?;
        }
    }
    let mut s = format!("{:3} ", h.glonass.len());
    for (k, (slot, ch)) in h.glonass.iter().enumerate() {
        if k > 0 && k % 8 == 0 {
            line(w, &s, "GLONASS SLOT / FRQ #")?;
            s = "    ".to_string();
        }
        s.push_str(&format!("R{slot:02} {ch:2} "));
    }
    line(w, &s, "GLONASS SLOT / FRQ #")?;
    line(
        w,
        " C1C    0.000 C1P    0.000 C2C    0.000 C2P    0.000",
        "GLONASS COD/PHS/BIS",
    )?;
    line(w, "", "END OF HEADER")
}

/// Write an observation epoch (flag 0) with its satellites.
pub fn write_epoch(w: &mut dyn Write, t: Epoch, sats: &[SatObs]) -> Result<()> {
    // The record is put together here and handed over at once: a write per field through
    // `dyn Write` cost more than the formatting.
    let mut text = Vec::with_capacity(64 + sats.len() * (4 + 16 * 8));
    writeln!(text, "> {}  0{:3}{:21}", epoch_fields(t), sats.len(), "")?;
    for s in sats {
        write!(text, "{}", s.sv)?;
        for o in &s.obs {
            if o.value.is_nan() {
                text.extend_from_slice(b"              ");
            } else {
                let mut buf = [0u8; 32];
                let n = f14_3(o.value % 1e9, &mut buf);
                text.extend_from_slice(&buf[..n]);
            }
            let digit = |d: u8| if d == 0 { b' ' } else { b'0' + d.min(9) };
            text.extend_from_slice(&[digit(o.lli), digit(o.ssi)]);
        }
        text.push(b'\n');
    }
    w.write_all(&text)?;
    Ok(())
}

/// `v` as F14.3 into `buf`, exactly as `format!("{v:14.3}")` prints it (ties to even on the
/// exact binary value); returns the length. Integer arithmetic where the rounding direction
/// is beyond doubt (|v| < 10⁹, not within 10⁻⁶ of a tie, not rounding to zero), the standard
/// formatter otherwise: observation files are mostly these numbers, and the standard
/// formatter's exact path costs half of a conversion.
pub fn f14_3(v: f64, buf: &mut [u8; 32]) -> usize {
    let scaled = v.abs() * 1e3;
    let frac = scaled - scaled.floor();
    // Error of `scaled` below 1.2e-4 for |v| < 1e9: a fraction this far from 0.5 rounds surely.
    if v.abs() < 1e9 && (frac - 0.5).abs() > 1e-3 {
        let n = scaled.round() as u64;
        if n > 0 {
            let mut digits = [0u8; 20];
            let mut k = 0;
            let mut m = n;
            while m > 0 || k < 4 {
                digits[k] = b'0' + (m % 10) as u8;
                m /= 10;
                k += 1;
            }
            let len = k + 1 + usize::from(v < 0.0);
            let pad = 14usize.saturating_sub(len);
            buf[..pad].fill(b' ');
            let mut i = pad;
            if v < 0.0 {
                buf[i] = b'-';
                i += 1;
            }
            for d in (3..k).rev() {
                buf[i] = digits[d];
                i += 1;
            }
            buf[i] = b'.';
            buf[i + 1..i + 4].copy_from_slice(&[digits[2], digits[1], digits[0]]);
            return i + 4;
        }
    }
    let s = format!("{v:14.3}");
    let n = s.len().min(buf.len());
    buf[..n].copy_from_slice(&s.as_bytes()[..n]);
    n
}

/// Write a flag-5 (external event) record at `t`, followed by `comments` as COMMENT lines.
pub fn write_event(w: &mut dyn Write, t: Epoch, comments: &[String]) -> Result<()> {
    writeln!(w, "> {}  5{:3}", epoch_fields(t), comments.len())?;
    for c in comments {
        line(w, c, "COMMENT")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::f14_3;

    #[test]
    fn f14_3_prints_as_the_standard_formatter() {
        let mut buf = [0u8; 32];
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut vals = vec![
            0.0,
            -0.0,
            0.0004,
            -0.0004,
            0.0005,
            0.0015,
            -1336.3125,
            1e9 - 1e-4,
        ];
        for k in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let u = (x >> 11) as f64 / (1u64 << 53) as f64;
            let v = match k % 4 {
                0 => (u - 0.5) * 2e8,                       // phase
                1 => 2e7 + u * 1e7,                         // pseudorange
                2 => ((u - 0.5) * 1e4) as f32 as f64,       // Doppler from f32: ties
                _ => ((u - 0.5) * 1e6 * 8.0).round() / 8e3, // exact eighths of a thousandth
            };
            vals.push(v);
        }
        for v in vals {
            let n = f14_3(v, &mut buf);
            assert_eq!(
                std::str::from_utf8(&buf[..n]).unwrap(),
                format!("{v:14.3}"),
                "{v:e}"
            );
        }
    }
}
