//! NGA's raw EGM2008 grids as the agency distributes them (`Und_min2.5x2.5_egm2008_isw=82_
//! WGS84_TideFree_SE`, `Und_min1x1_…`): Fortran unformatted sequential records, one per row
//! from the north: a 4-byte byte count, that many bytes of float32 undulations (metres) from
//! west to east, the count again. `_SE` files are little-endian ("small endian"), `_BE`
//! big-endian; the order is told from the counts.
//!
//! The whole grids say where they lie by their size alone: 4,321 rows of 8,640 values at
//! 2.5′ and 10,801 rows of 21,600 at 1′, from 90° N to 90° S and from 0° E eastwards (NGA's
//! own interpolation programs read them so). Any other size (a crop) needs a [`Placement`].

use super::{GeoidGrid, Placement};
use gnss::error::{Error, Result};
use std::path::Path;

/// The record structure of a file: byte order and values per row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Records {
    /// Whether the counts and values are little-endian.
    pub little: bool,
    /// Rows (records) in the file.
    pub rows: usize,
    /// Values per row.
    pub cols: usize,
}

/// The record structure when `b` is a whole number of equal Fortran records of float32
/// values, each opened and closed by the same byte count (at least two rows of two values).
pub fn records(b: &[u8]) -> Option<Records> {
    let head: [u8; 4] = b.get(..4)?.try_into().ok()?;
    [true, false].into_iter().find_map(|little| {
        let count = if little {
            u32::from_le_bytes(head)
        } else {
            u32::from_be_bytes(head)
        } as usize;
        let record = count.checked_add(8)?;
        let ok = count >= 8
            && count.is_multiple_of(4)
            && b.len().is_multiple_of(record)
            && b.len() / record >= 2
            && b.chunks_exact(record)
                .all(|r| r[..4] == head && r[record - 4..] == head);
        ok.then_some(Records {
            little,
            rows: b.len() / record,
            cols: count / 4,
        })
    })
}

/// NGA's whole grids: (rows, columns, spacing in arc-minutes).
const WHOLE: [(usize, usize, f64); 2] = [(4321, 8640, 2.5), (10801, 21600, 1.0)];

/// The grid of a file with `records`, placed by its size (a whole grid) or by `placement`.
pub(super) fn read(
    path: &Path,
    b: &[u8],
    records: Records,
    placement: Option<Placement>,
) -> Result<GeoidGrid> {
    let Records { little, rows, cols } = records;
    let whole = WHOLE
        .iter()
        .find(|w| (w.0, w.1) == (rows, cols))
        .map(|w| Placement {
            north: 90.0,
            west: 0.0,
            minutes: w.2,
        });
    let place = match (whole, placement) {
        (Some(w), None) => w,
        (None, Some(p)) => p,
        (Some(_), Some(_)) => {
            return Err(Error::input(
                path,
                format!("NGA's whole grid ({rows} rows of {cols}) places itself: give the file without @LAT,LON,MINUTES"),
            ))
        }
        (None, None) => {
            return Err(Error::input(
                path,
                format!(
                    "an NGA raw grid of {rows} rows of {cols} values is not one of NGA's whole grids (4321 × 8640 at 2.5′, 10801 × 21600 at 1′), so it does not say where it lies: give its north-west node and spacing after the name, e.g. --height geoid:{}@38,-123,2.5 (latitude of the north row, longitude of the west column in degrees, spacing in arc-minutes)",
                    path.display()
                ),
            ))
        }
    };
    let step = place.minutes / 60.0;
    let south = place.north - (rows - 1) as f64 * step;
    if south < -90.0 - 1e-9 {
        return Err(Error::input(
            path,
            format!(
                "{rows} rows every {}′ from {}° N reach {south:.4}°, south of the pole: check the placement",
                place.minutes, place.north
            ),
        ));
    }
    let record = 4 * cols + 8;
    Ok(GeoidGrid::from_north_rows(
        path,
        (south, place.west),
        (step, step),
        (rows, cols),
        |r, c| {
            let at = r * record + 4 + 4 * c;
            let bytes: [u8; 4] = b[at..at + 4].try_into().expect("4 bytes");
            let x = if little {
                f32::from_le_bytes(bytes)
            } else {
                f32::from_be_bytes(bytes)
            };
            if x.is_finite() && x.abs() < 1000.0 {
                x
            } else {
                f32::NAN
            }
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file of `rows` records of `vals` each, in the byte order asked for.
    fn fortran(rows: &[Vec<f32>], little: bool) -> Vec<u8> {
        let mut b = Vec::new();
        for r in rows {
            let count = (4 * r.len()) as u32;
            let c = if little {
                count.to_le_bytes()
            } else {
                count.to_be_bytes()
            };
            b.extend_from_slice(&c);
            for v in r {
                b.extend_from_slice(&if little {
                    v.to_le_bytes()
                } else {
                    v.to_be_bytes()
                });
            }
            b.extend_from_slice(&c);
        }
        b
    }

    #[test]
    fn records_are_told_in_either_byte_order_and_crops_need_a_placement() {
        let rows = vec![vec![10.0f32, 11.0, 12.0], vec![20.0, 21.0, 22.0]];
        for little in [true, false] {
            let b = fortran(&rows, little);
            let rec = records(&b).expect("records");
            assert_eq!((rec.little, rec.rows, rec.cols), (little, 2, 3));
            let p = testkit::scratch_file("nga-crop.bin", &b);
            let e = read(&p, &b, rec, None).unwrap_err().to_string();
            assert!(
                e.contains("@38,-123,2.5") && e.contains("2 rows of 3"),
                "{e}"
            );
            let place = Placement::parse("51,-1,60").unwrap();
            let g = read(&p, &b, rec, Some(place)).unwrap();
            // North row first in the file: 51° N holds 10, 11, 12; 50° N 20, 21, 22.
            assert!((g.undulation(51.0, -1.0).unwrap() - 10.0).abs() < 1e-9);
            assert!((g.undulation(50.5, -0.5).unwrap() - 15.5).abs() < 1e-6);
            let e = g.undulation(52.0, 0.0).unwrap_err().to_string();
            assert!(
                e.contains("latitude 52.000000") && e.contains("50.000000° to 51.000000°"),
                "{e}"
            );
        }
        // Text, a GTX header, a truncated record: no record structure.
        assert!(records(b"50 0 40\n50 1 41\n51 0 42\n51 1 44\n").is_none());
        let mut cut = fortran(&rows, true);
        cut.pop();
        assert!(records(&cut).is_none());
        assert!(Placement::parse("38,-123").is_none());
        assert!(Placement::parse("38,-123,0").is_none());
    }
}
