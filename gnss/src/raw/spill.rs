//! The epochs and time marks of a log's single decoding pass, kept for the writing pass in a
//! temporary file: `convert` decodes a log once (the header's observation types are known
//! only at its end) and writes the RINEX records from this file, so memory stays bounded
//! whatever the log's size and the log's frames are checked and decoded only once.
//!
//! What enters: the [`RinexOut`] records of a log in RINEX order, each kept with its length.
//! What leaves: blocks of whole records, and each record decoded, bit for bit as it entered
//! (blocks let the writing pass format their records on all threads). The file lives in the
//! output's folder: on Linux a file without a name (`O_TMPFILE`), which no kill can leave
//! behind; elsewhere, or where the file system refuses that, a hidden sibling of the output
//! (`.NAME.PID.spill`), removed from its folder as soon as it is opened where the system
//! allows it (Unix), otherwise when the reader is dropped (a killed run's is removed by the
//! next run writing the same output).

use super::records::RinexOut;
use super::ubx_obs::{RawEpoch, RawSat, RawSignal};
use crate::sv::{Constellation, Sv};
use hifitime::Epoch;
use std::fs::File;
use std::io::{BufReader, BufWriter, Error, ErrorKind, Read, Result, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

const EPOCH: u8 = 1;
const EVENT: u8 = 2;

/// The file an item list is written to.
pub struct Spill {
    w: BufWriter<File>,
    buf: Vec<u8>,
    path: Leftover,
}

/// The spill's path while it is still in its folder (not on Unix); removed when dropped.
struct Leftover(Option<PathBuf>);

impl Drop for Leftover {
    fn drop(&mut self) {
        if let Some(p) = self.0.take() {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// A file without a name in folder `dir` (Linux `O_TMPFILE`: it never appears in the folder,
/// and goes when closed, also when the process is killed); `None` where that is not to be had.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn unnamed_in(dir: &Path) -> Option<File> {
    use std::os::unix::fs::OpenOptionsExt;
    File::options()
        .read(true)
        .write(true)
        .custom_flags(libc::O_TMPFILE)
        .mode(0o600)
        .open(dir)
        .ok()
}

/// A file without a name: not to be had on this system.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn unnamed_in(_dir: &Path) -> Option<File> {
    None
}

impl Spill {
    /// A new, empty spill file beside `out`.
    pub fn create(out: &Path) -> Result<Spill> {
        let path = crate::atomic::sibling(out, "spill");
        if let Some(file) = path.parent().and_then(unnamed_in) {
            return Ok(Spill::of(file, None));
        }
        let file = File::options()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(&path)?;
        // Unlinked at once where an open file may be: nothing is left behind by a killed run.
        let path = if cfg!(unix) && std::fs::remove_file(&path).is_ok() {
            None
        } else {
            Some(path)
        };
        Ok(Spill::of(file, path))
    }

    /// A spill writing to `file`, whose name (when it has one in a folder) is `path`.
    fn of(file: File, path: Option<PathBuf>) -> Spill {
        Spill {
            w: BufWriter::with_capacity(1 << 18, file),
            buf: Vec::with_capacity(4096),
            path: Leftover(path),
        }
    }

    /// Keep one record.
    pub fn push(&mut self, o: &RinexOut) -> Result<()> {
        self.buf.clear();
        self.buf.extend_from_slice(&[0; 4]);
        match o {
            RinexOut::Epoch(_, e) => encode_epoch(e, &mut self.buf),
            RinexOut::Event(t, c) => encode_event(*t, c, &mut self.buf),
        }
        let n = (self.buf.len() - 4) as u32;
        self.buf[..4].copy_from_slice(&n.to_le_bytes());
        self.w.write_all(&self.buf)
    }

    /// The items kept, from the first.
    pub fn into_reader(self) -> Result<SpillReader> {
        let mut file = self.w.into_inner().map_err(|e| e.into_error())?;
        file.seek(SeekFrom::Start(0))?;
        Ok(SpillReader {
            r: BufReader::with_capacity(1 << 18, file),
            _path: self.path,
        })
    }
}

/// Reads a spill's items back in order.
pub struct SpillReader {
    r: BufReader<File>,
    _path: Leftover,
}

/// Whole records of a spill, one after the other.
#[derive(Default)]
pub struct Block {
    bytes: Vec<u8>,
    ends: Vec<usize>,
}

impl Block {
    /// The records of the block, each as [`decode`] takes it.
    pub fn records(&self) -> Vec<&[u8]> {
        let mut start = 0;
        self.ends
            .iter()
            .map(|&end| {
                let r = &self.bytes[start..end];
                start = end;
                r
            })
            .collect()
    }
}

impl SpillReader {
    /// The next records, about `size` bytes of them (at least one); `None` after the last.
    pub fn next_block(&mut self, size: usize) -> Result<Option<Block>> {
        let mut b = Block::default();
        while b.bytes.len() < size {
            let mut len = [0u8; 4];
            match self.r.read(&mut len[..1])? {
                0 => break,
                _ => self.r.read_exact(&mut len[1..])?,
            }
            let n = u32::from_le_bytes(len) as usize;
            let start = b.bytes.len();
            b.bytes.resize(start + n, 0);
            self.r.read_exact(&mut b.bytes[start..])?;
            b.ends.push(start + n);
        }
        Ok((!b.ends.is_empty()).then_some(b))
    }
}

/// One record of a [`Block`].
pub fn decode(rec: &[u8]) -> Result<RinexOut> {
    let mut r = rec;
    let [tag] = bytes(&mut r)?;
    match tag {
        EPOCH => {
            let e = decode_epoch(&mut r)?;
            Ok(RinexOut::Epoch(super::items::gpst(e.week, e.tow), e))
        }
        EVENT => {
            let (t, c) = decode_event(&mut r)?;
            Ok(RinexOut::Event(t, c))
        }
        _ => Err(damaged()),
    }
}

fn damaged() -> Error {
    Error::new(ErrorKind::InvalidData, "spill file damaged")
}

fn encode_epoch(e: &RawEpoch, b: &mut Vec<u8>) {
    b.push(EPOCH);
    b.extend_from_slice(&e.week.to_le_bytes());
    b.extend_from_slice(&e.tow.to_bits().to_le_bytes());
    b.extend_from_slice(&(e.glonass.len() as u32).to_le_bytes());
    for &(slot, ch) in &e.glonass {
        b.extend_from_slice(&[slot, ch as u8]);
    }
    b.extend_from_slice(&(e.sats.len() as u32).to_le_bytes());
    for s in &e.sats {
        let mask = s
            .sig
            .iter()
            .enumerate()
            .fold(0u8, |m, (k, g)| m | u8::from(g.is_some()) << k);
        b.extend_from_slice(&[s.sv.sys.letter() as u8, s.sv.prn, mask]);
        for g in s.sig.iter().flatten() {
            b.extend_from_slice(&g.code);
            for v in [g.pr, g.cp, g.doppler, g.cno] {
                b.extend_from_slice(&v.to_bits().to_le_bytes());
            }
            b.push(g.lli);
        }
    }
}

fn encode_event(t: Epoch, comments: &[String], b: &mut Vec<u8>) {
    b.push(EVENT);
    b.extend_from_slice(&t.to_gpst_nanoseconds().unwrap_or(0).to_le_bytes());
    b.extend_from_slice(&(comments.len() as u32).to_le_bytes());
    for c in comments {
        b.extend_from_slice(&(c.len() as u32).to_le_bytes());
        b.extend_from_slice(c.as_bytes());
    }
}

fn bytes<const N: usize>(r: &mut impl Read) -> Result<[u8; N]> {
    let mut a = [0u8; N];
    r.read_exact(&mut a)?;
    Ok(a)
}

fn f64_of(r: &mut impl Read) -> Result<f64> {
    Ok(f64::from_bits(u64::from_le_bytes(bytes(r)?)))
}

fn decode_epoch(r: &mut &[u8]) -> Result<RawEpoch> {
    let week = u16::from_le_bytes(bytes(r)?);
    let tow = f64_of(r)?;
    let n = u32::from_le_bytes(bytes(r)?) as usize;
    let mut glonass = Vec::with_capacity(n.min(256));
    for _ in 0..n {
        let [slot, ch] = bytes(r)?;
        glonass.push((slot, ch as i8));
    }
    let n = u32::from_le_bytes(bytes(r)?) as usize;
    let mut sats = Vec::with_capacity(n.min(256));
    for _ in 0..n {
        let [sys, prn, mask] = bytes(r)?;
        let sys = Constellation::from_letter(sys).ok_or_else(damaged)?;
        let mut sig = [None; crate::raw::ubx_obs::SLOTS];
        for (k, g) in sig.iter_mut().enumerate() {
            if mask >> k & 1 == 1 {
                let code = bytes(r)?;
                let [pr, cp, doppler, cno] = [f64_of(r)?, f64_of(r)?, f64_of(r)?, f64_of(r)?];
                let [lli] = bytes(r)?;
                *g = Some(RawSignal {
                    code,
                    pr,
                    cp,
                    doppler,
                    cno,
                    lli,
                });
            }
        }
        sats.push(RawSat {
            sv: Sv::new(sys, prn),
            sig,
        });
    }
    Ok(RawEpoch {
        week,
        tow,
        sats,
        glonass,
    })
}

fn decode_event(r: &mut &[u8]) -> Result<(Epoch, Vec<String>)> {
    let t = Epoch::from_gpst_nanoseconds(u64::from_le_bytes(bytes(r)?));
    let n = u32::from_le_bytes(bytes(r)?) as usize;
    let mut comments = Vec::with_capacity(n.min(16));
    for _ in 0..n {
        let len = u32::from_le_bytes(bytes(r)?) as usize;
        let text = r.get(..len).ok_or_else(damaged)?;
        comments.push(String::from_utf8_lossy(text).into_owned());
        *r = &r[len..];
    }
    Ok((t, comments))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_come_back_bit_for_bit() {
        let dir = testkit::scratch_dir("spill");
        let sig = |pr: f64| RawSignal {
            code: *b"1C",
            pr,
            cp: -1.5e8 - 0.123,
            doppler: f64::from(-1234.5f32),
            cno: 41.25,
            lli: 2,
        };
        let e = RawEpoch {
            week: 2315,
            tow: 345_600.1,
            sats: vec![
                RawSat {
                    sv: Sv::new(Constellation::Glonass, 7),
                    sig: [Some(sig(2.1e7 + 1e-9)), None, Some(sig(0.0)), None, None],
                },
                RawSat {
                    sv: Sv::new(Constellation::BeiDou, 61),
                    sig: [None, Some(sig(3.8e7)), None, None, None],
                },
            ],
            glonass: vec![(7, -4)],
        };
        let t = super::super::items::gpst(2315, 345_600.123_456_7);
        let c = vec![" Time mark is not valid".to_string(), "é".to_string()];
        let mut s = Spill::create(&dir.join("out.obs")).unwrap();
        let te = super::super::items::gpst(e.week, e.tow);
        s.push(&RinexOut::Epoch(te, e.clone())).unwrap();
        s.push(&RinexOut::Event(t, c.clone())).unwrap();
        s.push(&RinexOut::Event(t, vec![])).unwrap();
        s.push(&RinexOut::Epoch(te, e.clone())).unwrap();
        let mut r = s.into_reader().unwrap();
        let mut back = Vec::new();
        // blocks of one record and more
        for size in [1, 1 << 20] {
            let b = r.next_block(size).unwrap().unwrap();
            for rec in b.records() {
                back.push(decode(rec).unwrap());
            }
        }
        assert!(r.next_block(1).unwrap().is_none());
        drop(r);
        assert_eq!(back.len(), 4);
        assert!(matches!(&back[0], RinexOut::Epoch(x, y) if *x == te && *y == e));
        assert!(matches!(&back[1], RinexOut::Event(x, y) if *x == t && *y == c));
        assert!(matches!(&back[2], RinexOut::Event(x, y) if *x == t && y.is_empty()));
        assert!(matches!(&back[3], RinexOut::Epoch(x, y) if *x == te && *y == e));
        // nothing left in the folder
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// On Linux the spill is opened without a name, so no kill between opening and unlinking
    /// can leave it in the output's folder (as one did under load before).
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    #[test]
    fn the_spill_never_has_a_name() {
        use std::os::fd::AsRawFd;
        let dir = testkit::scratch_dir("spill-unnamed");
        let s = Spill::create(&dir.join("out.obs")).unwrap();
        let fd = s.w.get_ref().as_raw_fd();
        let link = std::fs::read_link(format!("/proc/self/fd/{fd}")).unwrap();
        let link = link.to_string_lossy();
        assert!(link.starts_with(&*dir.to_string_lossy()), "{link}");
        assert!(!link.contains(".spill"), "opened under a name: {link}");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        drop(s);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
