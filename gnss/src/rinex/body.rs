//! The observation body: epoch lines, satellite records and special records, for RINEX 2 and
//! RINEX 3/4 text (CRINEX is first decoded to that text by [`super::crx`]).

use super::crx::Crx;
use super::header::ObsHeader;
use super::lines::{cols, parse_int, parse_real, Lines, MAX_WARNINGS};
use super::record::{Event, IngestStats, Obs, ObsEpoch, Record, SatObs, Warning};
use crate::error::Result;
use crate::sv::{Constellation, Sv};
use hifitime::{Epoch, TimeScale};

enum Source {
    Plain(Lines),
    Crx(Box<Crx>),
}

pub(crate) struct Body {
    src: Source,
    /// A line read ahead and not consumed yet (RINEX 2 resynchronisation).
    held: Option<(Vec<u8>, usize)>,
    line_buf: Vec<u8>,
    last_time: Option<Epoch>,
    pub warnings: Vec<Warning>,
    pub stats: IngestStats,
}

/// A satellite's observations without the blank fields that end its record, in a buffer of
/// their size: a header may list up to 999 types, and a short line must not cost memory for
/// all of them (`SatObs::get` reads the missing ones).
fn without_trailing_blanks(mut obs: Vec<Obs>) -> Vec<Obs> {
    while obs.last().is_some_and(Obs::is_blank) {
        obs.pop();
    }
    obs.shrink_to_fit();
    obs
}

impl Body {
    pub fn new_plain(src: Lines) -> Self {
        Self::with(Source::Plain(src))
    }
    pub fn new_crx(src: Lines, h: &ObsHeader) -> Self {
        Self::with(Source::Crx(Box::new(Crx::new(src, h))))
    }
    fn with(src: Source) -> Self {
        Body {
            src,
            held: None,
            line_buf: Vec::with_capacity(256),
            last_time: None,
            warnings: Vec::new(),
            stats: IngestStats::default(),
        }
    }

    fn warn(&mut self, line: usize, what: String) {
        if self.warnings.len() < MAX_WARNINGS {
            self.warnings.push(Warning { line, what });
        }
    }

    /// Fetch the next line into `self.line_buf`; returns its number or `None` at the end.
    fn fetch(&mut self) -> Result<Option<usize>> {
        if let Some((l, n)) = self.held.take() {
            self.line_buf = l;
            return Ok(Some(n));
        }
        let got = match &mut self.src {
            Source::Plain(src) => match src.next_line()? {
                Some(l) => {
                    self.line_buf.clear();
                    self.line_buf.extend_from_slice(l);
                    Some(src.line_no)
                }
                None => None,
            },
            Source::Crx(c) => c.next_line(&mut self.line_buf, &mut self.warnings)?,
        };
        if got.is_some() {
            self.stats.lines += 1;
        } else {
            self.stats.bytes = match &self.src {
                Source::Plain(s) => s.bytes,
                Source::Crx(c) => c.text_bytes(),
            };
        }
        Ok(got)
    }

    pub fn next_record(&mut self, h: &ObsHeader) -> Result<Option<Record>> {
        loop {
            let Some(line_no) = self.fetch()? else {
                return Ok(None);
            };
            if self.line_buf.iter().all(|c| c.is_ascii_whitespace()) {
                continue;
            }
            let head = if h.is_v2() {
                parse_epoch_v2(&self.line_buf, h.time_scale)
            } else {
                parse_epoch_v3(&self.line_buf, h.time_scale)
            };
            let Some(head) = head else {
                self.stats.skipped_lines += 1;
                let txt = String::from_utf8_lossy(&self.line_buf)
                    .trim_end()
                    .to_string();
                self.warn(
                    line_no,
                    format!("expected an epoch line, found '{txt}': line skipped"),
                );
                continue;
            };
            if (2..=5).contains(&head.flag) {
                return Ok(Some(Record::Event(self.read_event(head, line_no)?)));
            }
            if head.flag == 6 {
                self.stats.cycle_slip_records += 1;
                let n = head.nsat;
                let per = if h.is_v2() { self.v2_sat_lines(h) } else { 1 };
                let extra = if h.is_v2() { (n.max(1) - 1) / 12 } else { 0 };
                for _ in 0..(n * per + extra) {
                    if self.fetch()?.is_none() {
                        break;
                    }
                }
                continue;
            }
            let Some(time) = head.time else {
                self.stats.skipped_lines += 1;
                self.warn(line_no, "observation epoch without a date: skipped".into());
                continue;
            };
            if head.flag == 1 {
                self.stats.power_failures += 1;
            }
            let ep = if h.is_v2() {
                self.read_sats_v2(h, head, time, line_no)?
            } else {
                self.read_sats_v3(h, head, time, line_no)?
            };
            if let Some(prev) = self.last_time {
                if ep.time <= prev {
                    self.stats.non_increasing += 1;
                    self.warn(
                        line_no,
                        format!(
                            "epoch {} is not after the previous one ({}); kept in file order",
                            crate::time::format_ymdhms(ep.time),
                            crate::time::format_ymdhms(prev)
                        ),
                    );
                }
            }
            self.last_time = Some(ep.time);
            return Ok(Some(Record::Epoch(ep)));
        }
    }

    fn read_event(&mut self, head: EpochHead, line_no: usize) -> Result<Event> {
        let mut records = Vec::with_capacity(head.nsat);
        for _ in 0..head.nsat {
            match self.fetch()? {
                Some(_) => records.push(String::from_utf8_lossy(&self.line_buf).into_owned()),
                None => {
                    self.warn(
                        line_no,
                        format!(
                            "event record announces {} special lines but the file ends after {}",
                            head.nsat,
                            records.len()
                        ),
                    );
                    break;
                }
            }
        }
        if head.flag == 5 && head.time.is_none() {
            self.warn(line_no, "external event (flag 5) without a time".into());
        }
        Ok(Event {
            time: head.time,
            flag: head.flag,
            line: line_no,
            records,
        })
    }

    fn v2_sat_lines(&self, h: &ObsHeader) -> usize {
        h.types_of(Constellation::Gps).len().div_ceil(5).max(1)
    }

    fn read_sats_v3(
        &mut self,
        h: &ObsHeader,
        head: EpochHead,
        time: Epoch,
        line_no: usize,
    ) -> Result<ObsEpoch> {
        let mut sats = Vec::with_capacity(head.nsat.min(64));
        for i in 0..head.nsat {
            let Some(ln) = self.fetch()? else {
                self.warn(
                    line_no,
                    format!(
                        "last epoch truncated: {} of {} satellites present; kept what was read",
                        i, head.nsat
                    ),
                );
                break;
            };
            let line = &self.line_buf;
            let Some(sv) = Sv::parse(cols(line, 0, 3)) else {
                self.stats.dropped_sat_records += 1;
                let txt = String::from_utf8_lossy(line).trim_end().to_string();
                if line.first() == Some(&b'>') {
                    // The epoch announced more satellites than it has: resume at this epoch line.
                    self.held = Some((std::mem::take(&mut self.line_buf), ln));
                    self.warn(
                        line_no,
                        format!("epoch announces {} satellites but has {i}", head.nsat),
                    );
                    break;
                }
                self.warn(ln, format!("unreadable satellite record '{txt}': dropped"));
                continue;
            };
            let types = h.types_of(sv.sys);
            if types.is_empty() {
                self.stats.dropped_sat_records += 1;
                continue;
            }
            let mut obs = Vec::with_capacity(types.len());
            let mut bad = false;
            for k in 0..types.len() {
                let a = 3 + 16 * k;
                obs.push(parse_field(line, a, &mut bad));
            }
            if bad {
                self.stats.dropped_sat_records += 1;
                let txt = String::from_utf8_lossy(line).trim_end().to_string();
                self.warn(
                    ln,
                    format!("unreadable number in '{txt}': satellite {sv} dropped from this epoch"),
                );
                continue;
            }
            sats.push(SatObs {
                sv,
                obs: without_trailing_blanks(obs),
            });
        }
        Ok(ObsEpoch {
            time,
            flag: head.flag,
            clock_offset: head.clock,
            sats,
            line: line_no,
        })
    }

    fn read_sats_v2(
        &mut self,
        h: &ObsHeader,
        head: EpochHead,
        time: Epoch,
        line_no: usize,
    ) -> Result<ObsEpoch> {
        // Satellite list: 12 per line, continuation lines for more.
        let mut svs: Vec<Option<Sv>> = Vec::with_capacity(head.nsat.min(64));
        let mut first = true;
        while svs.len() < head.nsat {
            if !first && self.fetch()?.is_none() {
                break;
            }
            first = false;
            let line = &self.line_buf;
            for k in 0..12 {
                if svs.len() >= head.nsat {
                    break;
                }
                let a = 32 + 3 * k;
                svs.push(
                    Sv::parse(cols(line, a, a + 3)).map(|sv| match h.file_system {
                        Some(sys) if cols(line, a, a + 1) == b" " => Sv::new(sys, sv.prn),
                        _ => sv,
                    }),
                );
            }
        }
        let ntypes = h.types_of(Constellation::Gps).len();
        let per = ntypes.div_ceil(5).max(1);
        let mut sats = Vec::with_capacity(svs.len());
        'sat: for (i, sv) in svs.iter().enumerate() {
            let mut obs = Vec::with_capacity(ntypes);
            let mut bad = false;
            let mut first_ln = 0;
            for l in 0..per {
                let Some(ln) = self.fetch()? else {
                    self.warn(
                        line_no,
                        format!(
                            "last epoch truncated: {} of {} satellites present; kept what was read",
                            i,
                            svs.len()
                        ),
                    );
                    break 'sat;
                };
                if l == 0 {
                    first_ln = ln;
                }
                let line = &self.line_buf;
                for k in 0..5 {
                    if obs.len() >= ntypes {
                        break;
                    }
                    obs.push(parse_field(line, 16 * k, &mut bad));
                }
            }
            match sv {
                Some(sv) if !bad => sats.push(SatObs {
                    sv: *sv,
                    obs: without_trailing_blanks(obs),
                }),
                _ => {
                    self.stats.dropped_sat_records += 1;
                    let what = match sv {
                        Some(sv) => {
                            format!("unreadable number: satellite {sv} dropped from this epoch")
                        }
                        None => "unreadable satellite identifier: record dropped".to_string(),
                    };
                    self.warn(first_ln, what);
                }
            }
        }
        Ok(ObsEpoch {
            time,
            flag: head.flag,
            clock_offset: head.clock,
            sats,
            line: line_no,
        })
    }
}

#[inline]
fn parse_field(line: &[u8], a: usize, bad: &mut bool) -> Obs {
    let value = match parse_real(cols(line, a, a + 14)) {
        Ok(Some(v)) => v,
        Ok(None) => f64::NAN,
        Err(()) => {
            *bad = true;
            f64::NAN
        }
    };
    let flag = |i: usize| match line.get(i) {
        Some(c @ b'0'..=b'9') => c - b'0',
        _ => 0,
    };
    Obs {
        value,
        lli: flag(a + 14),
        ssi: flag(a + 15),
    }
}

#[derive(Clone, Copy, Debug)]
pub(crate) struct EpochHead {
    pub time: Option<Epoch>,
    pub flag: u8,
    pub nsat: usize,
    pub clock: Option<f64>,
}

/// Calendar fields to a GPST epoch; `None` for impossible dates.
pub(crate) fn make_epoch(
    y: i64,
    mo: i64,
    d: i64,
    hh: i64,
    mi: i64,
    sec: &[u8],
    ts: TimeScale,
) -> Option<Epoch> {
    if !crate::time::file_year(y)
        || !(1..=12).contains(&mo)
        || !(1..=31).contains(&d)
        || !(0..=23).contains(&hh)
        || !(0..=59).contains(&mi)
    {
        return None;
    }
    let (s, ns) = parse_seconds(sec)?;
    if s > 60 {
        return None;
    }
    let e = Epoch::maybe_from_gregorian(
        y as i32, mo as u8, d as u8, hh as u8, mi as u8, s as u8, ns, ts,
    )
    .ok()?;
    Some(crate::time::to_gpst(e))
}

/// Seconds field `ss.sssssss` → whole seconds and nanoseconds, exactly.
fn parse_seconds(f: &[u8]) -> Option<(u32, u32)> {
    let f = super::lines::trim(f);
    if f.is_empty() {
        return None;
    }
    let mut whole: u32 = 0;
    let mut ns: u32 = 0;
    let mut frac_digits = -1i32;
    for &c in f {
        match c {
            b'0'..=b'9' => {
                let d = (c - b'0') as u32;
                if frac_digits < 0 {
                    whole = whole.checked_mul(10)?.checked_add(d)?;
                } else if frac_digits < 9 {
                    ns = ns * 10 + d;
                    frac_digits += 1;
                }
            }
            b'.' if frac_digits < 0 => frac_digits = 0,
            _ => return None,
        }
    }
    for _ in frac_digits.max(0)..9 {
        ns *= 10;
    }
    Some((whole, ns))
}

fn int(line: &[u8], a: usize, b: usize) -> Option<i64> {
    parse_int(cols(line, a, b)).ok().flatten()
}

/// Two-digit RINEX 2 years: 80–99 → 1980–1999, 00–79 → 2000–2079.
fn full_year(yy: i64) -> i64 {
    match yy {
        0..=79 => 2000 + yy,
        80..=99 => 1900 + yy,
        _ => yy,
    }
}

/// Columns (0-based, end exclusive) of a calendar date and time written as fixed-width
/// integers (year, month, day, hour, minute) followed by a seconds field `ss.sssssss`: the
/// layout of RINEX observation epoch lines, RINEX navigation times of clock and SP3 epochs.
pub(crate) struct DateCols {
    /// Year, month, day, hour, minute.
    pub ymdhm: [(usize, usize); 5],
    /// Seconds.
    pub sec: (usize, usize),
    /// Read years below 100 as RINEX 2 two-digit years (80–99 → 19xx, 00–79 → 20xx).
    pub two_digit_years: bool,
}

impl DateCols {
    /// The epoch written in these columns of `line` in time scale `ts`, converted to GPST;
    /// `None` when a field is blank, unreadable or out of range.
    pub fn epoch(&self, line: &[u8], ts: TimeScale) -> Option<Epoch> {
        let f = |k: usize| int(line, self.ymdhm[k].0, self.ymdhm[k].1);
        let year = if self.two_digit_years {
            full_year(f(0)?)
        } else {
            f(0)?
        };
        make_epoch(
            year,
            f(1)?,
            f(2)?,
            f(3)?,
            f(4)?,
            cols(line, self.sec.0, self.sec.1),
            ts,
        )
    }
}

/// Column ranges (0-based, end exclusive) of an epoch line.
struct EpochCols {
    /// Date and time.
    time: DateCols,
    flag: (usize, usize),
    nsat: (usize, usize),
    clock: (usize, usize),
    /// Where a blank date means "no time" (allowed for special records).
    date: (usize, usize),
    /// First satellite identifier on the line (RINEX 2 lists satellites on the epoch line).
    first_sat: Option<(usize, usize)>,
}

/// RINEX 2 epoch line: ` yy mm dd hh mm ss.sssssss  f nnn` + satellites + clock (cols 69–80).
const V2: EpochCols = EpochCols {
    time: DateCols {
        ymdhm: [(0, 3), (3, 6), (6, 9), (9, 12), (12, 15)],
        sec: (15, 26),
        two_digit_years: true,
    },
    flag: (26, 29),
    nsat: (29, 32),
    clock: (68, 80),
    date: (0, 26),
    first_sat: Some((32, 35)),
};

/// RINEX 3/4 epoch line: `> yyyy mm dd hh mm ss.sssssss  f nnn      clock` (a two-digit year
/// is read as in RINEX 2).
const V3: EpochCols = EpochCols {
    time: DateCols {
        ymdhm: [(2, 6), (7, 9), (10, 12), (13, 15), (16, 18)],
        sec: (18, 29),
        two_digit_years: true,
    },
    flag: (31, 32),
    nsat: (32, 35),
    clock: (41, 56),
    date: (1, 29),
    first_sat: None,
};

pub(crate) fn parse_epoch_v2(line: &[u8], ts: TimeScale) -> Option<EpochHead> {
    parse_epoch(line, &V2, ts)
}

pub(crate) fn parse_epoch_v3(line: &[u8], ts: TimeScale) -> Option<EpochHead> {
    if line.first() != Some(&b'>') {
        return None;
    }
    parse_epoch(line, &V3, ts)
}

fn parse_epoch(line: &[u8], c: &EpochCols, ts: TimeScale) -> Option<EpochHead> {
    if line.len() < c.flag.1 {
        return None;
    }
    let flag = int(line, c.flag.0, c.flag.1).unwrap_or(0);
    let nsat = parse_int(cols(line, c.nsat.0, c.nsat.1)).ok()?.unwrap_or(0);
    if !(0..=6).contains(&flag) || !(0..=999).contains(&nsat) {
        return None;
    }
    let time = if cols(line, c.date.0, c.date.1).iter().all(|&b| b == b' ') {
        None
    } else {
        Some(c.time.epoch(line, ts)?)
    };
    if time.is_none() && flag < 2 {
        return None;
    }
    // Flag 0/1 lines of RINEX 2 must list satellites where they say they do.
    if let Some((a, b)) = c.first_sat {
        if flag < 2 && nsat > 0 && Sv::parse(cols(line, a, b)).is_none() {
            return None;
        }
    }
    Some(EpochHead {
        time,
        flag: flag as u8,
        nsat: nsat as usize,
        clock: parse_real(cols(line, c.clock.0, c.clock.1)).ok().flatten(),
    })
}
