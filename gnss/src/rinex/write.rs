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
    epoch_line(&mut text, t, sats.len());
    for s in sats {
        sv_field(&mut text, s.sv);
        for o in &s.obs {
            let mut f = [b' '; 16];
            if put_obs_field(&mut f, o.value, o.lli, o.ssi) {
                text.extend_from_slice(&f);
            } else {
                // wider than F14.3 (a value rounding to ±10⁹): all of it, then the digits
                let mut buf = [0u8; 32];
                let n = f14_3(o.value % 1e9, &mut buf);
                text.extend_from_slice(&buf[..n]);
                text.extend_from_slice(&f[14..]);
            }
        }
        text.push(b'\n');
    }
    w.write_all(&text)
}

/// The line opening an observation epoch (flag 0) of `n` satellites: as
/// `"> {epoch_fields}  0{n:3}"` and 21 blanks, its date worked out here rather than through
/// the time library's calendar and the formatter (a tenth of a conversion's time).
pub fn epoch_line(text: &mut Vec<u8>, t: Epoch, n: usize) {
    match t.to_gpst_nanoseconds() {
        Ok(ns) if n < 1000 => {
            text.extend_from_slice(b"> ");
            gpst_fields(text, ns);
            text.extend_from_slice(b"  0");
            text.extend_from_slice(&count3(n));
            text.extend_from_slice(&[b' '; 21]);
            text.push(b'\n');
        }
        _ => {
            let _ = writeln!(text, "> {}  0{:3}{:21}", epoch_fields(t), n, "");
        }
    }
}

/// `n` (< 1000) as `{n:3}`: the satellite count of an epoch line.
pub fn count3(n: usize) -> [u8; 3] {
    let digit = |d: usize| b'0' + (d % 10) as u8;
    [
        if n >= 100 { digit(n / 100) } else { b' ' },
        if n >= 10 { digit(n / 10) } else { b' ' },
        digit(n),
    ]
}

/// [`epoch_fields`] of the GPST time `ns` nanoseconds after the GPS epoch (1980-01-06): the
/// GPST calendar has no leap seconds, so the date is the civil date of the day count.
fn gpst_fields(text: &mut Vec<u8>, ns: u64) {
    const DAY: u64 = 86_400 * 10_000_000; // in 100 ns
    let ticks = ns.saturating_add(50) / 100;
    let (days, tod) = (ticks / DAY, ticks % DAY);
    // civil date of a day count since 1970-01-01 (the GPS epoch is its day 3657); the
    // algorithm of H. Hinnant's "chrono-compatible low-level date algorithms"
    let z = days as i64 + 3657 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    let (s, frac) = (tod / 10_000_000, tod % 10_000_000);
    let two = |v: u64| [b'0' + (v / 10) as u8, b'0' + (v % 10) as u8];
    let y = y as u64;
    text.extend_from_slice(&[
        b'0' + (y / 1000 % 10) as u8,
        b'0' + (y / 100 % 10) as u8,
        b'0' + (y / 10 % 10) as u8,
        b'0' + (y % 10) as u8,
        b' ',
    ]);
    for (v, sep) in [(m as u64, b' '), (d as u64, b' '), (s / 3600, b' ')] {
        text.extend_from_slice(&two(v));
        text.push(sep);
    }
    text.extend_from_slice(&two(s / 60 % 60));
    let sec = s % 60;
    text.extend_from_slice(&[
        b' ',
        if sec >= 10 {
            b'0' + (sec / 10) as u8
        } else {
            b' '
        },
        b'0' + (sec % 10) as u8,
        b'.',
    ]);
    let mut f = [b'0'; 7];
    let mut r = frac;
    for c in f.iter_mut().rev() {
        *c = b'0' + (r % 10) as u8;
        r /= 10;
    }
    text.extend_from_slice(&f);
}

/// A satellite's three characters, `G05`.
pub fn sv_field(text: &mut Vec<u8>, sv: crate::sv::Sv) {
    let p = sv.prn;
    if p < 100 {
        text.extend_from_slice(&[sv.sys.letter() as u8, b'0' + p / 10, b'0' + p % 10]);
    } else {
        let _ = write!(text, "{sv}");
    }
}

/// One observation as its 16 characters into `f`: F14.3 of the value modulo 10⁹ (blank when
/// NaN), then the LLI and SSI digits (blank when 0). Written in place, digit by digit: a
/// field put together elsewhere and copied over stalled on the copy. `false` when the value
/// needs more than 14 characters (one rounding to −10⁹ prints as 15): `f` then holds only
/// the digits, and the caller writes the value's whole text.
pub fn put_obs_field(f: &mut [u8; 16], value: f64, lli: u8, ssi: u8) -> bool {
    f.fill(b' ');
    let mut wide = false;
    if !value.is_nan() {
        let v = if value.abs() < 1e9 {
            value
        } else {
            value % 1e9
        };
        match thousandths(v.abs()).filter(|&n| n > 0 && n < 1_000_000_000_000) {
            Some(n) => put_digits14(&mut f[..14], n, v < 0.0),
            None => {
                let mut buf = [0u8; 32];
                let n = f14_3(v, &mut buf);
                if n > 14 {
                    wide = true;
                } else {
                    f[14 - n..14].copy_from_slice(&buf[..n]);
                }
            }
        }
    }
    let digit = |d: u8| if d == 0 { b' ' } else { b'0' + d.min(9) };
    f[14] = digit(lli);
    f[15] = digit(ssi);
    !wide
}

/// `v` as F14.3 into `buf`, exactly as `format!("{v:14.3}")` prints it (ties to even on the
/// exact binary value); returns the length. Integer arithmetic where the rounding is beyond
/// doubt (|v| < 10⁹, not rounding to zero, and either not within 10⁻³ of a tie or an exact
/// tie), the standard formatter otherwise: observation files are mostly these numbers, and
/// the standard formatter's exact path costs half of a conversion.
pub fn f14_3(v: f64, buf: &mut [u8; 32]) -> usize {
    if let Some(n) = thousandths(v.abs()).filter(|&n| n > 0 && n < 1_000_000_000_000) {
        put_digits14(&mut buf[..14], n, v < 0.0);
        return 14;
    }
    let s = format!("{v:14.3}");
    let n = s.len().min(buf.len());
    buf[..n].copy_from_slice(&s.as_bytes()[..n]);
    n
}

/// `a` (≥ 0) in thousandths rounded as the standard formatter rounds, where that is sure.
fn thousandths(a: f64) -> Option<u64> {
    if a.is_nan() || a >= 1e9 {
        return None;
    }
    let scaled = a * 1e3;
    // truncation through i64 (a single instruction each way, unlike u64) rather than floor
    let n = scaled as i64;
    let frac = scaled - n as f64;
    // Error of `scaled` below 1.2e-4 for a < 1e9: a fraction this far from 0.5 rounds surely.
    if (frac - 0.5).abs() > 1e-3 {
        return Some(n as u64 + u64::from(frac > 0.5));
    }
    // A binary value is an exact tie only as j/16 with j odd (then a·1000 = 125·j/2): the
    // formatter rounds it to the even thousandth. C/N0 in 1/16 dB-Hz (RTCM 3) is such a value.
    let t = a * 16.0;
    let j = t as u64;
    if j as f64 == t && j % 2 == 1 {
        let m = (j * 125 - 1) / 2;
        return Some(m + (m & 1));
    }
    None
}

/// 10⁰ … 10¹¹.
const POW10: [u64; 12] = {
    let mut p = [1u64; 12];
    let mut k = 1;
    while k < 12 {
        p[k] = p[k - 1] * 10;
        k += 1;
    }
    p
};

/// The two digits of 0 … 99, one after the other.
const PAIRS: &[u8; 200] = b"0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

/// `n` thousandths (0 < n < 10¹²) as F14.3 with its sign into `f` (14 bytes). Three groups
/// of four digits, each two pairs, worked out side by side (a digit at a time is one long
/// chain of divisions), written in place.
fn put_digits14(f: &mut [u8], n: u64, negative: bool) {
    let (c, r) = (n / 100_000_000, n % 100_000_000);
    let (b, a) = (r / 10_000, r % 10_000);
    let mut d = [0u8; 12];
    for (k, g) in [c, b, a].into_iter().enumerate() {
        let (hi, lo) = ((g / 100) as usize * 2, (g % 100) as usize * 2);
        d[4 * k..4 * k + 2].copy_from_slice(&PAIRS[hi..hi + 2]);
        d[4 * k + 2..4 * k + 4].copy_from_slice(&PAIRS[lo..lo + 2]);
    }
    // integer digits: all of n's above the three decimals, at least one
    let int = POW10[4..].iter().filter(|&&p| n >= p).count() + 1;
    f[1..10].copy_from_slice(&d[..9]);
    f[10] = b'.';
    f[11..14].copy_from_slice(&d[9..]);
    f[..10 - int].fill(b' ');
    if negative {
        f[9 - int] = b'-';
    }
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
    fn epoch_lines_print_as_the_calendar_and_formatter() {
        use super::{epoch_fields, epoch_line};
        use hifitime::Epoch;
        let mut x: u64 = 0x2545_F491_4F6C_DD1D;
        let mut times: Vec<u64> = vec![
            0,
            1,
            49,
            50,
            99_999_950,
            59_999_999_951,
            86_400_000_000_000 - 1,
        ];
        for _ in 0..100_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // 1980 to about 2160, at any nanosecond; and 10 Hz epochs
            let ns = x % (180 * 365 * 86_400 * 1_000_000_000);
            times.push(ns);
            times.push(ns / 100_000_000 * 100_000_000);
        }
        for ns in times {
            let t = Epoch::from_gpst_nanoseconds(ns);
            for n in [0, 7, 12, 123, 999, 1000] {
                let mut fast = Vec::new();
                epoch_line(&mut fast, t, n);
                let slow = format!("> {}  0{:3}{:21}\n", epoch_fields(t), n, "");
                assert_eq!(String::from_utf8(fast).unwrap(), slow, "{ns} {n}");
            }
        }
    }

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
            0.0625,
            -0.0625,
            0.1875,
            0.001,
            999_999_999.999_5,
            999_999_999.062_5,
            1e9,
            -1e9,
            1e15 + 0.5,
            f64::INFINITY,
            -999_999_999.999_6,
            -1_999_999_999.999_7,
            999_999_999.999_6,
        ];
        for k in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let u = (x >> 11) as f64 / (1u64 << 53) as f64;
            let v = match k % 6 {
                0 => (u - 0.5) * 2e8,                         // phase
                1 => 2e7 + u * 1e7,                           // pseudorange
                2 => ((u - 0.5) * 1e4) as f32 as f64,         // Doppler from f32: ties
                3 => ((u - 0.5) * 1e6 * 8.0).round() / 8e3,   // exact eighths of a thousandth
                4 => ((u - 0.5) * 1e4 * 16.0).round() / 16.0, // sixteenths: exact ties
                _ => ((u - 0.5) * 2e9 * 16.0).round() / 16.0, // sixteenths near 10⁹
            };
            vals.push(v);
        }
        for &v in &vals {
            // the in-place field equals the formatter's text of the value modulo 10⁹, or says
            // that text is wider
            let mut field = [0u8; 16];
            let fits = super::put_obs_field(&mut field, v, 1, 0);
            let s = format!("{:14.3}", v % 1e9);
            assert_eq!(fits, s.len() == 14, "{v}");
            if fits {
                assert_eq!(std::str::from_utf8(&field[..14]).unwrap(), s, "{v}");
            }
            assert_eq!(&field[14..], b"1 ");
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
