//! GNSS latency: an unknown time offset δ between the exposure time and the GNSS time of
//! each antenna position. The antenna at the exposure is the trajectory at t + δ, linearised
//! with the antenna velocity v the antenna table carries (`ve,vn,vu`) or the trajectory
//! gives: `X_A(t + δ) ≈ X_A,obs + v·δ`. So δ > 0 means the exposure happened δ seconds after
//! the time the GNSS position was given for (the camera fires late, or the event is stamped
//! early); the antenna position used is shifted by +v·δ along the track.
//!
//! Groups (`[gnss] latency`): `block` — one δ for every antenna position; `flight` — one δ
//! per flight, a flight being the antenna positions in time order up to a gap longer than
//! [`FLIGHT_GAP_S`] (a landing, a battery or card change; turns between strips are shorter).
//! Each group is a block `Key::Latency(LatencyId(g))` of one value, start `latency_start`,
//! with a prior of σ `latency_sigma` about it when that is given (else free).
//!
//! δ is only observable when the velocities differ between images whose positions are
//! otherwise known: strips flown in both directions separate it from a constant offset, and
//! a lever arm along the track is as correlated with it as a constant along-track offset.

use super::error::{problem_err as err, AdjustError};
use super::frame::LocalFrame;
use super::groups::GROUP_PRIOR;
use super::project::{GnssSection, Project};
use super::sections::LatencyGroup;
use nalgebra::{DVector, Vector3};
use photo::factors::Prior;
use photo::lsq::{BuildError, Key, LatencyId, Loss, Noise, Problem, Value};

/// Gap between consecutive antenna times (s) that starts a new flight.
pub const FLIGHT_GAP_S: f64 = 600.0;

/// A latency group (key `Latency(LatencyId(index))`).
#[derive(Clone, Debug)]
pub struct LatencyBlock {
    /// Its name ("block", "flight 2").
    pub name: String,
    /// How many antenna positions it holds.
    pub antennas: usize,
}

/// The latency groups and the group of each image.
#[derive(Clone, Debug, Default)]
pub(super) struct Latencies {
    /// The groups, by `LatencyId`.
    pub blocks: Vec<LatencyBlock>,
    /// The group of each image (None: no antenna, or no latency).
    pub of_image: Vec<Option<usize>>,
}

/// The latency group of every image with an antenna; refused when a latency is asked for and
/// an antenna position has no velocity.
pub(super) fn groups(p: &Project, antenna_of: &[Option<usize>]) -> Result<Latencies, AdjustError> {
    let mut lat = Latencies {
        blocks: Vec::new(),
        of_image: vec![None; antenna_of.len()],
    };
    let Some(gs) = p.file.gnss.as_ref() else {
        return Ok(lat);
    };
    let mut used: Vec<(f64, usize)> = antenna_of
        .iter()
        .enumerate()
        .filter_map(|(i, a)| a.map(|k| (p.antennas[k].time.to_gpst_seconds(), i)))
        .collect();
    if gs.latency == LatencyGroup::None || used.is_empty() {
        return Ok(lat);
    }
    let bare: Vec<&str> = used
        .iter()
        .filter_map(|&(_, i)| antenna_of[i].map(|k| &p.antennas[k]))
        .filter(|a| a.vel_enu.is_none())
        .map(|a| a.image.as_str())
        .collect();
    if !bare.is_empty() {
        return Err(err(format!(
            "[gnss] latency = \"{}\" needs the antenna velocity, and {} antenna position(s) have none (first: {}): give the antenna table the columns ve,vn,vu (m/s, ENU; `ppkat exposures --format antenna` writes them), use a trajectory, or set latency = \"none\"",
            if gs.latency == LatencyGroup::Block { "block" } else { "flight" },
            bare.len(),
            bare[..bare.len().min(5)].join(", ")
        )));
    }
    used.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut last = f64::NEG_INFINITY;
    for (t, i) in used {
        let new_group = match gs.latency {
            LatencyGroup::Flight => t - last > FLIGHT_GAP_S,
            _ => lat.blocks.is_empty(),
        };
        if new_group {
            let name = match gs.latency {
                LatencyGroup::Flight => format!("flight {}", lat.blocks.len() + 1),
                _ => "block".to_string(),
            };
            lat.blocks.push(LatencyBlock { name, antennas: 0 });
        }
        last = t;
        let g = lat.blocks.len() - 1;
        lat.blocks[g].antennas += 1;
        lat.of_image[i] = Some(g);
    }
    Ok(lat)
}

/// Add a block per latency group (start `latency_start`) and, with `latency_sigma`, its prior.
pub(super) fn add_blocks(
    gs: &GnssSection,
    pr: &mut Problem,
    lat: &Latencies,
    loss: Loss,
) -> Result<(), BuildError> {
    for g in 0..lat.blocks.len() {
        let key = Key::Latency(LatencyId::from(g));
        let start = DVector::from_element(1, gs.latency_start);
        pr.add_block(key, Value::Vector(start.clone()))?;
        if let Some(s) = gs.latency_sigma {
            let f = Prior::new(key, start);
            pr.add_factor(f, Noise::sigmas(&[s.max(1e-9)]), loss, GROUP_PRIOR)?;
        }
    }
    Ok(())
}

/// The latency group of image `i` (antenna record `k`) and its antenna velocity in the
/// adjustment frame, when the image has a latency.
pub(super) fn of(
    p: &Project,
    frame: &LocalFrame,
    lat: &Latencies,
    i: usize,
    k: usize,
) -> Option<(LatencyId, Vector3<f64>)> {
    let g = lat.of_image.get(i).copied().flatten()?;
    let a = &p.antennas[k];
    let v = a.vel_enu?;
    Some((LatencyId::from(g), frame.from_enu_at(&a.pos) * v))
}
