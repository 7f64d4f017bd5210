//! Exposure names: the labels other tools join the camera stations to their photographs by.
//! An exposure is never labelled a bare 1, 2, 3 (Metashape, Pix4D and ODM look the labels up
//! as image names).
//!
//! Enters: the exposures as read ([`ExposureEvent`]s: RINEX events named [`generic`], DJI MRK
//! lines named [`dji`] from their index, CSV rows by their `id` column), and optionally a
//! names file ([`read_file`]) or the photographs of a folder ([`super::photos::Photo`]).
//! Leaves: the exposures renamed ([`apply_file`], [`apply_photos`]) and, for photos, which
//! photograph belongs to which exposure ([`PhotoMatch`]) and what could not be paired.

use super::events::ExposureEvent;
use super::photos::{check_times, Photo};
use gnss::error::{Error, Result};
use hifitime::Epoch;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

pub use super::events::{dji, generic};

/// The sequence number of a DJI photograph or exposure name: the last `_`-separated group of
/// 1–6 digits of the name without its extension (`DJI_0042.JPG` → 42,
/// `DJI_20240105123456_0042_V.JPG` → 42); `None` when there is none.
pub fn sequence_number(name: &str) -> Option<u32> {
    let stem = match name.rsplit_once('.') {
        Some((s, ext)) if !ext.is_empty() && ext.chars().all(|c| c.is_ascii_alphanumeric()) => s,
        _ => name,
    };
    stem.split('_')
        .rev()
        .find(|g| (1..=6).contains(&g.len()) && g.chars().all(|c| c.is_ascii_digit()))
        .and_then(|g| g.parse().ok())
}

/// Read a names file: one name per line in exposure order; blank lines and lines starting
/// with `#` are skipped. A name with a comma or a double quote (it would break the CSV
/// exports), or one given twice, is an error naming the line.
pub fn read_file(path: &Path) -> Result<Vec<String>> {
    let text = std::fs::read_to_string(path).map_err(Error::io(path))?;
    let mut names = Vec::new();
    let mut seen: HashMap<String, usize> = HashMap::new();
    for (i, line) in text.lines().enumerate() {
        let name = line.trim();
        if name.is_empty() || name.starts_with('#') {
            continue;
        }
        if name.contains([',', '"']) {
            return Err(Error::parse(
                path,
                i + 1,
                format!(
                    "'{name}': a name cannot hold a comma or a double quote (the exports are CSV)"
                ),
            ));
        }
        if let Some(first) = seen.insert(name.to_string(), i + 1) {
            return Err(Error::parse(
                path,
                i + 1,
                format!("'{name}' is already the name on line {first}: every exposure needs its own name"),
            ));
        }
        names.push(name.to_string());
    }
    if names.is_empty() {
        return Err(Error::input(
            path,
            "no name in the file (one name per line expected)",
        ));
    }
    Ok(names)
}

/// Name the exposures from a names file read by [`read_file`], in their order. A count that
/// differs from the exposures' is an error naming both counts and the file.
pub fn apply_file(events: &mut [ExposureEvent], names: Vec<String>, path: &Path) -> Result<()> {
    if names.len() != events.len() {
        return Err(Error::input(
            path,
            format!(
                "{} names for {} exposures: give one name per exposure, in exposure order",
                names.len(),
                events.len()
            ),
        ));
    }
    for (e, n) in events.iter_mut().zip(names) {
        e.id = n;
    }
    Ok(())
}

/// How the photographs of a folder were paired with the exposures.
#[derive(Clone, Debug, Default)]
pub struct PhotoMatch {
    /// The photographs in the order used (see [`match_photos`]).
    pub photos: Vec<Photo>,
    /// (exposure index, photo index) of every pair.
    pub pairs: Vec<(usize, usize)>,
    /// Photographs without an exposure, with the reason.
    pub unpaired_photos: Vec<(PathBuf, String)>,
    /// Exposures without a photograph (by their names before renaming), with the reason.
    pub unpaired_exposures: Vec<String>,
    /// How the photos were ordered or paired, for the report.
    pub order: &'static str,
}

/// Pair the photographs with the exposures. DJI MRK exposures are paired by number: MRK index
/// ↔ the `DJI_NNNN` number of the file name ([`sequence_number`]); what finds no partner is
/// listed, and `Err` only when nothing pairs. Other exposures are paired in time order (exact
/// duplicate times taken once) with the photos sorted by EXIF capture time when every photo
/// has one, else by file name; `Err` (from [`check_times`]) when the counts or the rhythm of
/// the capture times disagree.
pub fn match_photos(
    events: &[ExposureEvent],
    mut photos: Vec<Photo>,
) -> std::result::Result<PhotoMatch, String> {
    if !events.is_empty() && events.iter().all(|e| e.mrk.is_some()) {
        return match_by_number(events, photos);
    }
    let by_time = photos.iter().all(|p| p.taken.is_some());
    if by_time {
        photos.sort_by(|a, b| {
            a.taken
                .partial_cmp(&b.taken)
                .unwrap_or(std::cmp::Ordering::Equal)
                .then_with(|| a.name.cmp(&b.name))
        });
    } else {
        photos.sort_by(|a, b| a.name.cmp(&b.name));
    }
    let order = time_order(events);
    let times: Vec<Epoch> = order.iter().map(|&k| events[k].time).collect();
    check_times(&photos, &times)?;
    Ok(PhotoMatch {
        pairs: order.into_iter().zip(0..photos.len()).collect(),
        photos,
        order: if by_time {
            "in EXIF capture-time order"
        } else {
            "in file-name order (not every photo has an EXIF capture time)"
        },
        ..PhotoMatch::default()
    })
}

/// Indices of the exposures in time order, an exposure at the same time as the one before
/// left out (it is refused as a duplicate later).
fn time_order(events: &[ExposureEvent]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..events.len()).collect();
    idx.sort_by(|&a, &b| {
        events[a]
            .time
            .partial_cmp(&events[b].time)
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut out: Vec<usize> = Vec::with_capacity(idx.len());
    for k in idx {
        match out.last() {
            Some(&l) if (events[k].time - events[l].time).to_seconds().abs() < 1e-6 => {}
            _ => out.push(k),
        }
    }
    out
}

/// MRK index ↔ `DJI_NNNN` number.
fn match_by_number(
    events: &[ExposureEvent],
    mut photos: Vec<Photo>,
) -> std::result::Result<PhotoMatch, String> {
    photos.sort_by(|a, b| a.name.cmp(&b.name));
    let mut by_number: HashMap<u32, usize> = HashMap::new();
    let mut m = PhotoMatch {
        order: "by MRK index = DJI_NNNN number of the file name",
        ..PhotoMatch::default()
    };
    for (j, p) in photos.iter().enumerate() {
        match sequence_number(&p.name) {
            Some(n) => {
                if let Some(&other) = by_number.get(&n) {
                    m.unpaired_photos.push((
                        p.path.clone(),
                        format!("its number {n} is also that of {}", photos[other].name),
                    ));
                } else {
                    by_number.insert(n, j);
                }
            }
            None => m.unpaired_photos.push((
                p.path.clone(),
                "no DJI_NNNN number in the file name to pair it with an MRK line".into(),
            )),
        }
    }
    let mut used = vec![false; photos.len()];
    for (k, e) in events.iter().enumerate() {
        match sequence_number(&e.id).and_then(|n| by_number.get(&n)) {
            Some(&j) if !used[j] => {
                used[j] = true;
                m.pairs.push((k, j));
            }
            _ => m.unpaired_exposures.push(format!(
                "exposure {} (MRK line {}): no photograph with its number in the folder",
                e.id, e.line
            )),
        }
    }
    if m.pairs.is_empty() {
        let range = |v: Vec<u32>| match (v.iter().min(), v.iter().max()) {
            (Some(a), Some(b)) => format!("{a}–{b}"),
            _ => "none".into(),
        };
        return Err(format!(
            "no photo's DJI_NNNN number is an MRK index (MRK indices {}, photo numbers {}): check that the folder holds this flight's photos",
            range(events.iter().filter_map(|e| sequence_number(&e.id)).collect()),
            range(by_number.keys().copied().collect())
        ));
    }
    for (j, p) in photos.iter().enumerate() {
        if by_number.values().any(|&x| x == j) && !used[j] {
            m.unpaired_photos.push((
                p.path.clone(),
                format!(
                    "no MRK line with index {}",
                    sequence_number(&p.name).unwrap_or_default()
                ),
            ));
        }
    }
    m.photos = photos;
    Ok(m)
}

/// Name every paired exposure by its photograph's file name.
pub fn apply_photos(events: &mut [ExposureEvent], m: &PhotoMatch) {
    for &(k, j) in &m.pairs {
        events[k].id = m.photos[j].name.clone();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hifitime::Duration;

    fn event(id: &str, t: f64, mrk: bool) -> ExposureEvent {
        ExposureEvent {
            id: id.into(),
            time: Epoch::from_gpst_seconds(1.4e9) + Duration::from_seconds(t),
            line: 0,
            mrk: mrk.then(|| super::super::events::MrkInfo {
                offset_neu: [0.0; 3],
                position: gnss::frame::Geodetic::from_degrees(0.0, 0.0, 0.0),
                sigma: [0.01; 3],
                quality: 50,
            }),
        }
    }

    fn photo(name: &str, taken: Option<f64>) -> Photo {
        Photo {
            path: PathBuf::from("/photos").join(name),
            name: name.into(),
            taken,
            exif_error: None,
        }
    }

    fn temp_file(name: &str, text: &str) -> PathBuf {
        testkit::scratch_file(&format!("names/{name}"), text)
    }

    #[test]
    fn generic_and_dji_names() {
        assert_eq!(generic(0), "E0001");
        assert_eq!(generic(12344), "E12345");
        assert_eq!(dji(7), "DJI_0007");
        assert_eq!(dji(12345), "DJI_12345");
        assert_eq!(sequence_number("DJI_0042.JPG"), Some(42));
        assert_eq!(sequence_number("DJI_20240105123456_0042_V.JPG"), Some(42));
        assert_eq!(sequence_number("DJI_0007"), Some(7));
        assert_eq!(sequence_number("IMG.JPG"), None);
    }

    #[test]
    fn a_names_file_names_in_order_and_counts_must_agree() {
        let p = temp_file("names.txt", "# flight 3\nA-001\n\n  A-002 \n#x\nA-003\n");
        let names = read_file(&p).unwrap();
        assert_eq!(names, ["A-001", "A-002", "A-003"]);
        let mut evs: Vec<_> = (0..3)
            .map(|k| event(&generic(k), k as f64, false))
            .collect();
        apply_file(&mut evs, names.clone(), &p).unwrap();
        assert_eq!(evs[2].id, "A-003");
        let e = apply_file(&mut evs[..2], names, &p)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("3 names for 2 exposures") && e.contains("names.txt"),
            "{e}"
        );
        let dup = temp_file("dup.txt", "A\nB\nA\n");
        let e = read_file(&dup).unwrap_err().to_string();
        assert!(e.contains("dup.txt:3") && e.contains("line 1"), "{e}");
        let comma = temp_file("comma.txt", "A,1\n");
        assert!(read_file(&comma)
            .unwrap_err()
            .to_string()
            .contains("comma.txt:1"));
    }

    #[test]
    fn photos_pair_in_capture_time_order() {
        // File names out of capture order (the camera counter rolled over).
        let evs: Vec<_> = (0..3)
            .map(|k| event(&generic(k), 5.0 * k as f64, false))
            .collect();
        let photos = vec![
            photo("DJI_0001.JPG", Some(110.0)),
            photo("DJI_9998.JPG", Some(100.0)),
            photo("DJI_9999.JPG", Some(105.0)),
        ];
        let m = match_photos(&evs, photos).unwrap();
        let mut evs = evs;
        apply_photos(&mut evs, &m);
        let ids: Vec<&str> = evs.iter().map(|e| e.id.as_str()).collect();
        assert_eq!(ids, ["DJI_9998.JPG", "DJI_9999.JPG", "DJI_0001.JPG"]);
        // Without capture times on every photo: file-name order.
        let photos = vec![
            photo("b.jpg", None),
            photo("a.jpg", Some(1.0)),
            photo("c.jpg", None),
        ];
        let m = match_photos(&evs, photos).unwrap();
        assert!(m.order.contains("file-name"));
        assert_eq!(m.photos[m.pairs[0].1].name, "a.jpg");
        // A count mismatch says so.
        let why = match_photos(&evs[..2], vec![photo("a.jpg", None)]).unwrap_err();
        assert!(why.contains("1 photos, 2 exposures"), "{why}");
    }

    #[test]
    fn mrk_exposures_pair_by_dji_number() {
        let evs: Vec<_> = [1, 2, 3]
            .iter()
            .map(|&k| event(&dji(k), k as f64, true))
            .collect();
        // Photo 2 is missing, photo 9 has no MRK line.
        let photos = vec![
            photo("DJI_0003.JPG", None),
            photo("DJI_0001.JPG", None),
            photo("DJI_0009.JPG", None),
        ];
        let m = match_photos(&evs, photos).unwrap();
        let mut named = evs.clone();
        apply_photos(&mut named, &m);
        assert_eq!(named[0].id, "DJI_0001.JPG");
        assert_eq!(named[1].id, "DJI_0002", "no photo: keeps its DJI name");
        assert_eq!(named[2].id, "DJI_0003.JPG");
        assert_eq!(m.unpaired_exposures.len(), 1);
        assert!(m.unpaired_exposures[0].contains("DJI_0002"));
        assert_eq!(m.unpaired_photos.len(), 1);
        assert!(m.unpaired_photos[0].1.contains("no MRK line with index 9"));
        // Nothing pairs: an error naming both ranges.
        let why = match_photos(&evs, vec![photo("DJI_0018.JPG", None)]).unwrap_err();
        assert!(
            why.contains("MRK indices 1–3") && why.contains("18–18"),
            "{why}"
        );
    }
}
