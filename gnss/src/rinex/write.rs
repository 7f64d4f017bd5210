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

fn line(w: &mut dyn Write, a: &str, label: &str) -> Result<()> {
    writeln!(w, "{a:<60.60}{label}")
}

/// Write the header.
pub fn write_header(w: &mut dyn Write, h: &HeaderOut) -> Result<()> {
    line(
        w,
        "     3.04           OBSERVATION DATA    M: Mixed",
        "RINEX VERSION / TYPE",
    )?;
    line(
        w,
        &format!("{:<20}{:<20}", h.program, "ppkat"),
        "PGM / RUN BY / DATE",
    )?;
    for c in &h.comments {
        line(w, c, "COMMENT")?;
    }
    line(w, &h.marker, "MARKER NAME")?;
    line(w, "", "OBSERVER / AGENCY")?;
    line(w, "", "REC # / TYPE / VERS")?;
    line(w, "", "ANT # / TYPE")?;
    let [x, y, z] = h.approx;
    line(
        w,
        &format!("{x:14.4}{y:14.4}{z:14.4}"),
        "APPROX POSITION XYZ",
    )?;
    line(
        w,
        &format!("{:14.4}{:14.4}{:14.4}", 0.0, 0.0, 0.0),
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
    writeln!(w, "> {}  0{:3}{:21}", epoch_fields(t), sats.len(), "")?;
    for s in sats {
        write!(w, "{}", s.sv)?;
        for o in &s.obs {
            if o.value.is_nan() {
                w.write_all(b"              ")?;
            } else {
                write!(w, "{:14.3}", o.value % 1e9)?;
            }
            let digit = |d: u8| if d == 0 { b' ' } else { b'0' + d.min(9) };
            w.write_all(&[digit(o.lli), digit(o.ssi)])?;
        }
        writeln!(w)?;
    }
    Ok(())
}

/// Write a flag-5 (external event) record at `t`, followed by `comments` as COMMENT lines.
pub fn write_event(w: &mut dyn Write, t: Epoch, comments: &[String]) -> Result<()> {
    writeln!(w, "> {}  5{:3}", epoch_fields(t), comments.len())?;
    for c in comments {
        line(w, c, "COMMENT")?;
    }
    Ok(())
}
