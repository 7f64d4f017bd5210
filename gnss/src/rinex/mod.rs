//! RINEX ingest: observation files (2.x, 3.x, 4.x; Hatanaka CRINEX 1 and 3; gzip) streamed into
//! an ordered epoch list plus every event record (flags 2–5, camera exposures among them), and
//! navigation files into ephemeris records.
//!
//! ppkat owns this parser rather than using the `rinex` crate for observations: that crate
//! drops epochs with flags 2–5, holds the whole file in memory, its streaming CRINEX decoder
//! fails on real files, and it parses at about a quarter of the speed we need. It is kept as an
//! independent cross-check in the tests.

pub(crate) mod body;
mod crx;
mod header;
pub mod lines;
pub mod nav;
mod record;
pub mod summary;
pub mod write;
pub mod write_nav;

pub use header::{AntennaDelta, ObsHeader};
pub use record::{Event, IngestStats, Obs, ObsCode, ObsEpoch, Record, SatObs, Warning};

use crate::error::{Error, Result};
use crate::sv::Constellation;
use lines::Lines;
use std::path::Path;

/// A streaming reader of an observation file.
pub struct ObsReader {
    header: ObsHeader,
    body: body::Body,
}

impl ObsReader {
    /// Open a RINEX (plain, gzip or Hatanaka) observation file and read its header.
    pub fn open(path: &Path) -> Result<Self> {
        let mut src = Lines::open(path)?;
        // Peek the first line for a CRINEX header.
        let first = match src.next_line()? {
            Some(l) => l.to_vec(),
            None => return Err(Error::input(path, "the file is empty")),
        };
        if lines::label(&first) == b"CRINEX VERS   / TYPE" {
            let v = lines::parse_real(lines::cols(&first, 0, 9))
                .ok()
                .flatten()
                .unwrap_or(0.0);
            if !(1.0..4.0).contains(&v) {
                return Err(Error::input(
                    path,
                    format!("CRINEX version {v} is not supported (1.x and 3.x are)"),
                ));
            }
            src.next_line()?; // CRINEX PROG / DATE
            let header = header::read_header(&mut src, Some(v))?;
            let body = body::Body::new_crx(src, &header);
            return Ok(ObsReader { header, body });
        }
        // Plain RINEX: re-open so the header reader sees the first line.
        let mut src = Lines::open(path)?;
        let header = header::read_header(&mut src, None)?;
        let body = body::Body::new_plain(src);
        Ok(ObsReader { header, body })
    }

    /// The header.
    pub fn header(&self) -> &ObsHeader {
        &self.header
    }

    /// The next epoch or event, in file order; `None` at the end of the file.
    pub fn next_record(&mut self) -> Result<Option<Record>> {
        self.body.next_record(&self.header)
    }

    /// What was wrong so far (reading went on).
    pub fn warnings(&self) -> &[Warning] {
        &self.body.warnings
    }
    /// Counts so far.
    pub fn stats(&self) -> &IngestStats {
        &self.body.stats
    }
}

/// A whole observation file in memory: header, epochs, events, and what was wrong with it.
#[derive(Clone, Debug)]
pub struct ObsFile {
    /// The file read.
    pub path: std::path::PathBuf,
    /// Its header.
    pub header: ObsHeader,
    /// Observation epochs in file order.
    pub epochs: Vec<ObsEpoch>,
    /// Special records (flags 2–5), camera events among them.
    pub events: Vec<Event>,
    /// What was wrong (reading went on).
    pub warnings: Vec<Warning>,
    /// Counts gathered while reading.
    pub stats: IngestStats,
}

impl ObsFile {
    /// Read a whole observation file (RINEX 2/3/4, plain, gzip or Hatanaka).
    pub fn read(path: &Path) -> Result<Self> {
        let mut r = ObsReader::open(path)?;
        let mut epochs = Vec::new();
        let mut events = Vec::new();
        while let Some(rec) = r.next_record()? {
            match rec {
                Record::Epoch(e) => epochs.push(e),
                Record::Event(e) => events.push(e),
            }
        }
        if epochs.is_empty() && events.is_empty() {
            return Err(Error::input(
                path,
                "the file has a header but no observation epochs",
            ));
        }
        Ok(ObsFile {
            path: path.to_path_buf(),
            header: r.header,
            epochs,
            events,
            warnings: r.body.warnings,
            stats: r.body.stats,
        })
    }

    /// Camera exposures: the flag-5 events that carry a time.
    pub fn exposure_events(&self) -> impl Iterator<Item = &Event> {
        self.events
            .iter()
            .filter(|e| e.flag == 5 && e.time.is_some())
    }

    /// Systems seen in the epochs.
    pub fn systems(&self) -> Vec<Constellation> {
        let mut seen = [false; 7];
        for e in &self.epochs {
            for s in &e.sats {
                seen[s.sv.sys.index()] = true;
            }
        }
        Constellation::ALL
            .iter()
            .copied()
            .filter(|c| seen[c.index()])
            .collect()
    }
}

/// Write the plain RINEX text of an observation file (gunzipped, Hatanaka-decompressed) to `w`.
pub fn write_plain_text(path: &Path, w: &mut dyn std::io::Write) -> Result<()> {
    let io = Error::io(path);
    let mut src = Lines::open(path)?;
    let first = match src.next_line()? {
        Some(l) => l.to_vec(),
        None => return Err(Error::input(path, "the file is empty")),
    };
    if lines::label(&first) != b"CRINEX VERS   / TYPE" {
        w.write_all(&first).map_err(io)?;
        w.write_all(b"\n").map_err(io)?;
        while let Some(l) = src.next_line()? {
            w.write_all(l).map_err(io)?;
            w.write_all(b"\n").map_err(io)?;
        }
        return Ok(());
    }
    // CRINEX: copy the header (after the two CRINEX lines), then decode the body.
    let crinex = lines::parse_real(lines::cols(&first, 0, 9)).ok().flatten();
    src.next_line()?;
    let mut header_text = Vec::new();
    loop {
        let Some(l) = src.next_line()? else {
            return Err(Error::input(path, "the header has no END OF HEADER line"));
        };
        header_text.extend_from_slice(l);
        header_text.push(b'\n');
        if lines::label(l) == b"END OF HEADER" {
            break;
        }
    }
    w.write_all(&header_text).map_err(io)?;
    let mut hsrc = Lines::from_reader(path, std::io::Cursor::new(header_text));
    let header = header::read_header(&mut hsrc, crinex)?;
    let mut crx = crx::Crx::new(src, &header);
    let mut buf = Vec::new();
    let mut warnings = Vec::new();
    while crx.next_line(&mut buf, &mut warnings)?.is_some() {
        w.write_all(&buf).map_err(io)?;
        w.write_all(b"\n").map_err(io)?;
    }
    Ok(())
}
