//! Hatanaka (CRINEX 1 and 3) decompression to RINEX text lines, one epoch at a time.
//!
//! Format (Hatanaka 2008): the epoch line is sent as a text difference against the previous
//! one (`&`/`>` at the start re-initialises it), then a receiver-clock line, then one line per
//! satellite holding its observations as integer thousandths, each either `n&value`
//! (initialise an n-th order difference) or the n-th difference, followed by the LLI/SSI text
//! difference. Special records (flags 2–5) are carried uncompressed.

use super::header::ObsHeader;
use super::lines::Lines;
use super::record::Warning;
use crate::error::{Error, Result};
use crate::sv::{Constellation, Sv};
use std::collections::HashMap;

const MAX_ORDER: usize = 9;

#[derive(Clone, Copy, Default)]
struct Diff {
    u: [i64; MAX_ORDER + 1],
    order: usize,
    k: usize,
    live: bool,
}

impl Diff {
    fn init(&mut self, order: usize, v: i64) {
        *self = Diff {
            order: order.min(MAX_ORDER),
            live: true,
            ..Diff::default()
        };
        self.u[0] = v;
    }
    fn decode(&mut self, d: i64) -> i64 {
        if self.k < self.order {
            self.k += 1;
        }
        let k = self.k;
        self.u[k] = d;
        for i in (0..k).rev() {
            self.u[i] = self.u[i].wrapping_add(self.u[i + 1]);
        }
        self.u[0]
    }
    /// The next value from a compressed field: blank → missing (the difference chain
    /// stops), `n&value` → initialised, a difference → decoded. `Err` for junk or for a
    /// difference with no live chain to add it to.
    fn take(&mut self, f: &[u8]) -> std::result::Result<Option<i64>, ()> {
        if f.is_empty() {
            self.live = false;
            return Ok(None);
        }
        match parse_num(f) {
            Some((Some(o), v)) => {
                self.init(o, v);
                Ok(Some(v))
            }
            Some((None, d)) if self.live => Ok(Some(self.decode(d))),
            _ => Err(()),
        }
    }
}

#[derive(Default)]
struct SatState {
    fields: Vec<Diff>,
    flags: Vec<u8>,
}

pub(crate) struct Crx {
    src: Lines,
    v3: bool,
    ntypes: [usize; 7],
    file_system: Option<Constellation>,
    epoch_text: Vec<u8>,
    clock: Diff,
    sats: HashMap<Sv, SatState>,
    prev: Vec<Sv>,
    queue: Vec<Vec<u8>>,
    qpos: usize,
    qline: usize,
    text_bytes: u64,
    values: Vec<Option<i64>>,
}

fn apply_text_diff(old: &mut Vec<u8>, diff: &[u8]) {
    for (i, &c) in diff.iter().enumerate() {
        if i >= old.len() {
            old.push(b' ');
        }
        match c {
            b' ' => {}
            b'&' => old[i] = b' ',
            _ => old[i] = c,
        }
    }
}

/// Write `v` thousandths as a right-aligned F14.3 field (or `width`/`decimals` in general).
fn push_fixed(out: &mut Vec<u8>, v: i64, width: usize, decimals: u32) {
    let scale = 10i64.pow(decimals);
    let neg = v < 0;
    let a = v.unsigned_abs();
    let ip = a / scale as u64;
    let fp = a % scale as u64;
    let mut tmp = [0u8; 40];
    let mut n = 0;
    // fraction digits, reversed
    let mut f = fp;
    for _ in 0..decimals {
        tmp[n] = b'0' + (f % 10) as u8;
        f /= 10;
        n += 1;
    }
    tmp[n] = b'.';
    n += 1;
    let mut i = ip;
    loop {
        tmp[n] = b'0' + (i % 10) as u8;
        i /= 10;
        n += 1;
        if i == 0 {
            break;
        }
    }
    if neg {
        tmp[n] = b'-';
        n += 1;
    }
    for _ in n..width {
        out.push(b' ');
    }
    for k in (0..n).rev() {
        out.push(tmp[k]);
    }
}

/// Parse a compressed numeric field: `Some((Some(order), value))` for `n&value`,
/// `Some((None, diff))` for a difference, `None` for junk.
fn parse_num(f: &[u8]) -> Option<(Option<usize>, i64)> {
    let (order, digits) = match f.iter().position(|&c| c == b'&') {
        Some(p) => {
            let o = std::str::from_utf8(&f[..p]).ok()?.parse::<usize>().ok()?;
            (Some(o), &f[p + 1..])
        }
        None => (None, f),
    };
    let v = std::str::from_utf8(digits).ok()?.parse::<i64>().ok()?;
    Some((order, v))
}

impl Crx {
    pub fn new(src: Lines, h: &ObsHeader) -> Self {
        let mut ntypes = [0usize; 7];
        for (sys, t) in &h.obs_types {
            ntypes[sys.index()] = t.len();
        }
        Crx {
            src,
            v3: !h.is_v2(),
            ntypes,
            file_system: h.file_system,
            epoch_text: Vec::new(),
            clock: Diff::default(),
            sats: HashMap::new(),
            prev: Vec::new(),
            queue: Vec::new(),
            qpos: 0,
            qline: 0,
            text_bytes: 0,
            values: Vec::new(),
        }
    }

    pub fn text_bytes(&self) -> u64 {
        self.text_bytes
    }

    /// The next decompressed RINEX line into `out`, with the compressed line number of its epoch.
    pub fn next_line(
        &mut self,
        out: &mut Vec<u8>,
        warnings: &mut Vec<Warning>,
    ) -> Result<Option<usize>> {
        loop {
            if self.qpos < self.queue.len() {
                out.clear();
                out.extend_from_slice(&self.queue[self.qpos]);
                self.qpos += 1;
                self.text_bytes += out.len() as u64 + 1;
                return Ok(Some(self.qline));
            }
            self.queue.clear();
            self.qpos = 0;
            if !self.decode_epoch(warnings)? {
                return Ok(None);
            }
        }
    }

    fn bad(&self, what: impl Into<String>) -> Error {
        Error::parse(&self.src.path, self.src.line_no, what)
    }

    fn new_line(&mut self) -> &mut Vec<u8> {
        self.queue.push(Vec::with_capacity(100));
        self.queue.last_mut().expect("just pushed")
    }

    /// Decode one epoch into the queue. Returns false at the end of the file.
    fn decode_epoch(&mut self, warnings: &mut Vec<Warning>) -> Result<bool> {
        if !self.next_epoch_text()? {
            return Ok(false);
        }
        let et = self.epoch_text.clone();
        let (flag_col, n_a, sat_a) = if self.v3 { (31, 32, 41) } else { (28, 29, 32) };
        let flag = et.get(flag_col).map(|c| c.wrapping_sub(b'0')).unwrap_or(0);
        let nsat = super::lines::parse_int(super::lines::cols(&et, n_a, n_a + 3))
            .ok()
            .flatten()
            .unwrap_or(0)
            .max(0) as usize;
        if (2..=5).contains(&flag) {
            self.queue_special_record(&et, nsat)?;
            return Ok(true);
        }
        let clock = self.decode_clock()?;
        let svs = self.epoch_satellites(&et, nsat, sat_a);
        self.queue_epoch_lines(&et, nsat, sat_a, clock);
        let mut present = Vec::with_capacity(nsat);
        for (i, sv) in svs.iter().enumerate() {
            let Some(data) = self.src.next_line()?.map(|l| l.to_vec()) else {
                push_capped(
                    warnings,
                    Warning {
                        line: self.qline,
                        what: format!("CRINEX epoch truncated after {i} of {nsat} satellites"),
                    },
                );
                break;
            };
            let Some(sv) = *sv else {
                // Keep the RINEX text consistent: an unreadable identifier gives an unreadable record.
                let l = self.new_line();
                l.extend_from_slice(b"???");
                continue;
            };
            present.push(sv);
            self.decode_satellite(sv, &data, warnings);
        }
        self.prev = present;
        Ok(true)
    }

    /// Read the next non-blank line as the epoch line's text difference and apply it to
    /// `epoch_text` (trailing blanks removed). Returns false at the end of the file.
    fn next_epoch_text(&mut self) -> Result<bool> {
        let line = loop {
            match self.src.next_line()? {
                None => return Ok(false),
                Some(l) if l.iter().all(|c| *c == b' ') => continue,
                Some(l) => break l.to_vec(),
            }
        };
        self.qline = self.src.line_no;
        let init_mark = if self.v3 { b'>' } else { b'&' };
        if line[0] == init_mark {
            self.epoch_text = line;
            if !self.v3 {
                self.epoch_text[0] = b' ';
            }
        } else if self.epoch_text.is_empty() {
            return Err(self.bad("CRINEX epoch difference before any initialised epoch line"));
        } else {
            apply_text_diff(&mut self.epoch_text, &line);
        }
        while self.epoch_text.last() == Some(&b' ') {
            self.epoch_text.pop();
        }
        Ok(true)
    }

    /// A special record (flags 2–5): the epoch line and its `nsat` uncompressed lines.
    fn queue_special_record(&mut self, et: &[u8], nsat: usize) -> Result<()> {
        let head_len = if self.v3 { 35 } else { 32 };
        let l = super::lines::cols(et, 0, head_len).to_vec();
        self.queue.push(l);
        for _ in 0..nsat {
            match self.src.next_line()? {
                Some(l) => {
                    let l = l.to_vec();
                    self.queue.push(l);
                }
                None => break,
            }
        }
        Ok(())
    }

    /// The receiver clock line: the clock offset in units of 10⁻¹² s (RINEX 3) or 10⁻⁹ s
    /// (RINEX 2), `None` when blank.
    fn decode_clock(&mut self) -> Result<Option<i64>> {
        let clock_line = self
            .src
            .next_line()?
            .map(|l| super::lines::trim(l).to_vec())
            .unwrap_or_default();
        self.clock
            .take(&clock_line)
            .map_err(|()| self.bad("unreadable CRINEX clock line"))
    }

    /// The satellites listed on the epoch text (the file's system for a blank letter).
    fn epoch_satellites(&self, et: &[u8], nsat: usize, sat_a: usize) -> Vec<Option<Sv>> {
        (0..nsat)
            .map(|i| {
                let a = sat_a + 3 * i;
                Sv::parse(super::lines::cols(et, a, a + 3)).map(|sv| match self.file_system {
                    Some(sys) if et.get(a) == Some(&b' ') => Sv::new(sys, sv.prn),
                    _ => sv,
                })
            })
            .collect()
    }

    /// The RINEX epoch line(s): RINEX 3 one line with the clock in columns 42–56; RINEX 2
    /// twelve satellites a line, the clock in columns 69–80 of the first.
    fn queue_epoch_lines(&mut self, et: &[u8], nsat: usize, sat_a: usize, clock: Option<i64>) {
        if self.v3 {
            let l = self.new_line();
            l.extend_from_slice(super::lines::cols(et, 0, 35));
            if let Some(c) = clock {
                while l.len() < 41 {
                    l.push(b' ');
                }
                push_fixed(l, c, 15, 12);
            }
            return;
        }
        for chunk in 0..nsat.div_ceil(12).max(1) {
            let l = self.new_line();
            if chunk == 0 {
                l.extend_from_slice(super::lines::cols(et, 0, 32));
            } else {
                l.extend_from_slice(&[b' '; 32]);
            }
            let a = sat_a + 36 * chunk;
            l.extend_from_slice(super::lines::cols(et, a, a + 36));
            if chunk == 0 {
                if let Some(c) = clock {
                    while l.len() < 68 {
                        l.push(b' ');
                    }
                    push_fixed(l, c, 12, 9);
                }
            }
        }
    }

    /// Decode one satellite's compressed line `data` and queue its RINEX record.
    fn decode_satellite(&mut self, sv: Sv, data: &[u8], warnings: &mut Vec<Warning>) {
        let nt = if self.v3 {
            self.ntypes[sv.sys.index()]
        } else {
            self.ntypes[Constellation::Gps.index()]
        };
        let was_present = self.prev.contains(&sv);
        let st = self.sats.entry(sv).or_default();
        if st.fields.len() != nt {
            st.fields = vec![Diff::default(); nt];
        }
        if !was_present {
            st.flags.clear();
        }
        let mut values = std::mem::take(&mut self.values);
        values.clear();
        let line_no = self.src.line_no;
        decode_fields(st, sv, data, &mut values, warnings, line_no);
        let flags = st.flags.clone();
        self.queue_sat_record(sv, &values, &flags);
        self.values = values;
    }

    /// The RINEX record of a satellite: RINEX 3 one line led by the satellite, RINEX 2 five
    /// values a line.
    fn queue_sat_record(&mut self, sv: Sv, values: &[Option<i64>], flags: &[u8]) {
        if self.v3 {
            let l = self.new_line();
            l.extend_from_slice(sv.to_string().as_bytes());
            for (k, v) in values.iter().enumerate() {
                push_value(l, *v, flags, k);
            }
            return;
        }
        for (c, vals) in values.chunks(5).enumerate() {
            let l = self.new_line();
            for (j, v) in vals.iter().enumerate() {
                push_value(l, *v, flags, 5 * c + j);
            }
        }
        if values.is_empty() {
            self.new_line();
        }
    }
}

/// Decode the `st.fields.len()` blank-separated fields of a satellite line into `values`, then
/// apply the LLI/SSI text difference that follows them. An undecodable field is left missing
/// with a warning at `line_no`.
fn decode_fields(
    st: &mut SatState,
    sv: Sv,
    data: &[u8],
    values: &mut Vec<Option<i64>>,
    warnings: &mut Vec<Warning>,
    line_no: usize,
) {
    let mut pos = 0usize;
    for field in st.fields.iter_mut() {
        let end = if pos >= data.len() {
            data.len()
        } else {
            data[pos..]
                .iter()
                .position(|&c| c == b' ')
                .map(|p| pos + p)
                .unwrap_or(data.len())
        };
        let f = if pos < data.len() {
            &data[pos..end]
        } else {
            &[][..]
        };
        pos = end + 1;
        let v = field.take(f).unwrap_or_else(|()| {
            field.live = false;
            push_capped(
                warnings,
                Warning {
                    line: line_no,
                    what: format!(
                        "CRINEX value '{}' of {sv} cannot be decoded: left missing",
                        String::from_utf8_lossy(f)
                    ),
                },
            );
            None
        });
        values.push(v);
    }
    if pos < data.len() {
        apply_text_diff(&mut st.flags, &data[pos..]);
    }
}

/// Value `k` as an F14.3 field (blank when missing) followed by its LLI and SSI flags.
fn push_value(l: &mut Vec<u8>, v: Option<i64>, flags: &[u8], k: usize) {
    let fl = |j: usize| flags.get(j).copied().unwrap_or(b' ');
    match v {
        Some(v) => push_fixed(l, v, 14, 3),
        None => l.extend_from_slice(&[b' '; 14]),
    }
    l.push(fl(2 * k));
    l.push(fl(2 * k + 1));
}

/// Keep a warning unless `warnings` already holds the body's cap of them (a file of garbage
/// must not fill memory with messages about itself).
fn push_capped(warnings: &mut Vec<Warning>, w: Warning) {
    if warnings.len() < super::lines::MAX_WARNINGS {
        warnings.push(w);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn differences_of_third_order_reconstruct_a_cubic() {
        let ys: Vec<i64> = (0..8)
            .map(|t: i64| 5 + 3 * t - 2 * t * t + t * t * t)
            .collect();
        let mut d = Diff::default();
        d.init(3, ys[0]);
        // The encoder's k-th order differences with ramp-up.
        let mut hist = vec![ys[0]];
        for (t, &y) in ys.iter().enumerate().skip(1) {
            hist.push(y);
            let k = t.min(3);
            let mut dd = hist.clone();
            for _ in 0..k {
                dd = dd.windows(2).map(|w| w[1] - w[0]).collect();
            }
            assert_eq!(d.decode(*dd.last().unwrap()), y);
        }
        let mut s = Vec::new();
        push_fixed(&mut s, -123, 14, 3);
        assert_eq!(&s[..], b"        -0.123");
        s.clear();
        push_fixed(&mut s, 23619095450, 14, 3);
        assert_eq!(&s[..], b"  23619095.450");
    }
}
