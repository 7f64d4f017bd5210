//! The low-cost walk shaped on a measured fingerprint (`simulate --builtin lowcost`, folder
//! `walk/`): a u-blox M8P-like rover on a pole staking out points 3–30 m from a base of the
//! same kind, 20 min at 1 Hz, GPS and GLONASS L1, under trees at half the points. Each of its
//! receivers carries the [`Impairments`] measured on a real walk of that kind
//! (`shared/data/lowcost-fingerprint`): time tags 9–13 ms off GPS time and 2–4 ms apart
//! between the receivers, wandering clocks, short arcs, phase jumps without a flag, slowly
//! varying code errors with excursions of metres, heavy-tailed Doppler; the base's log drops
//! most of its UBX epochs, and the RTCM 3 it sends beside them, with gaps of its own, fills
//! many of them.
//!
//! Enters: the folder and a random stream. Leaves: the files of [`super`]'s walk (the logs,
//! `nav.rnx`, `truth_trajectory.csv` at each rover epoch's true reception time, the RINEX of
//! each receiver, `ppk.toml`, `README.txt`) and a [`FieldWalk`] of what was simulated.

use super::impair::{ClockModel, Impairments};
use super::receiver::{self, GpsL1, LowCost, Profile, TrackStats};
use super::stakeout::Stakeout;
use super::{constellation, gpst, mixed_base_log, truth_at_instants};
use crate::constellation::GpsLayout;
use crate::error::SimError;
use crate::io::{write, write_bytes};
use crate::rng::Rng;
use gnss::frame::{Ecef, Enu, Geodetic};
use gnss::rinex::ObsFile;
use gnss::sv::Constellation;
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;
use std::fmt::Write as _;
use std::path::Path;

/// The base's site and the walk's start (GPST).
const SITE: (f64, f64, f64) = (47.37, 8.54, 410.0);
const START: &str = "2024-09-18T14:20:00";
/// The walk's length, seconds.
pub const SPAN_S: f64 = 1200.0;
/// The base's log: how long before the walk it starts, and its length, seconds.
const BASE_LEAD_S: f64 = 1500.0;
const BASE_SPAN_S: f64 = 3683.0;

/// What the walk's simulation holds.
#[derive(Clone, Debug)]
pub struct FieldWalk {
    /// The rover.
    pub rover: TrackStats,
    /// The base (every epoch it measured, logged or not).
    pub base: TrackStats,
    /// The base's position (ARP), ECEF.
    pub base_position: Ecef,
    /// Share of the walk spent standing.
    pub still_share: f64,
    /// Base epochs in the UBX log, in the RTCM 3 stream, in either.
    pub base_logged: (usize, usize, usize),
}

/// The M8P-like tracking both receivers share (the impairments carry most of what differs
/// from the model).
fn profile() -> Profile {
    Profile {
        half_s: [(0.5, 2.5), (0.5, 3.5)],
        half_offset_probability: 0.5,
        phase: (0.0015, 0.0, 3.0),
        unflagged_slip_rate: 0.0,
        canopy_db: (4.0, 4.0, 6.0),
        cn0: (27.0, 51.0),
        lock: (25.0, 28.0),
        code: (0.0, 0.0, 10.0),
        doppler: 0.0,
        glonass_icb: (0.0, 0.0),
    }
}

/// The rover's impairments, measured on the real walk's rover.
fn rover_impairments() -> Impairments {
    Impairments {
        clock: ClockModel {
            bias: -13.289e-3,
            drift: 2.479e-7,
            wander: 3.3e-10,
            ageing: 3.3e-12,
        },
        cn0: (29.0, 53.0, 0.6),
        fading: (1.0, 10.0, 0.5, 2.0),
        lock_loss: (0.002, 8.0),
        trouble: (10.0, 10.0),
        reacquire_s: (0.5, 2.0),
        jump_rate: (0.005, 13.0),
        jump_mix: (0.4, 0.25),
        half_flips: 0.5,
        code_white: (0.07, 13.0),
        code_mp: (1.0, 6.0, 1.2),
        code_mp_swing: (0.6, 60.0),
        excursion: (0.004, 25.0, 10.0, (3.0, 5.0)),
        doppler: (0.12, 35.0, (0.03, 30.0), 1.0),
        phase_white: 0.01,
    }
}

/// The base's impairments, measured on the real walk's base.
fn base_impairments() -> Impairments {
    Impairments {
        clock: ClockModel {
            bias: -10.65e-3,
            drift: 4.137e-7,
            wander: 5.0e-10,
            ageing: -1.5e-11,
        },
        fading: (1.0, 30.0, 0.25, 7.0),
        cn0: (25.0, 52.0, 0.6),
        lock_loss: (0.00012, 6.0),
        trouble: (20.0, 6.0),
        half_flips: 1.0,
        excursion: (0.003, 20.0, 10.0, (15.0, 30.0)),
        jump_rate: (0.0, 20.0),
        code_mp: (1.0, 10.0, 1.4),
        doppler: (0.08, 50.0, (0.003, 12.0), 0.45),
        ..rover_impairments()
    }
}

/// Which base epochs a log kept: runs and gaps drawn from `runs` (cumulative shares of runs
/// of 1, 2, 3 … epochs) and `gaps` (cumulative shares and the (min, max) seconds of each gap
/// class).
fn kept(n: usize, runs: &[f64], gaps: &[(f64, (usize, usize))], rng: &mut Rng) -> Vec<bool> {
    let mut keep = vec![false; n];
    let mut k = 0;
    while k < n {
        let u = rng.uniform();
        let run = 1 + runs.iter().take_while(|&&c| u > c).count();
        for x in keep.iter_mut().skip(k).take(run) {
            *x = true;
        }
        k += run;
        let u = rng.uniform();
        let (_, (lo, hi)) = gaps
            .iter()
            .find(|g| u <= g.0)
            .copied()
            .unwrap_or((1.0, (1, 1)));
        k += lo + (rng.uniform() * (hi - lo + 1) as f64) as usize;
    }
    keep
}

/// The walk into `dir`.
pub fn walk(dir: &Path, rng: &Rng) -> Result<FieldWalk, SimError> {
    let start = gpst(START)?;
    let site_geo = Geodetic::from_degrees(SITE.0, SITE.1, SITE.2);
    let site = site_geo.to_ecef();
    let systems = [Constellation::Gps, Constellation::Glonass];
    let base_start = start - Duration::from_seconds(BASE_LEAD_S);
    let base_end = base_start + Duration::from_seconds(BASE_SPAN_S);
    let (nav, eph) = constellation(
        dir,
        (base_start, base_end),
        66,
        &systems,
        GpsLayout::Operational31,
    )?;
    let klob = nav.gps_iono.unwrap_or_default();
    let path = Stakeout::draw(&mut rng.fork(4), SPAN_S + 10.0);
    let rot = gnss::frame::enu_rotation(&site_geo).transpose();
    let rover_at = |t: Epoch| {
        let (p, v) = path.at((t - start).to_seconds());
        (Enu(p).to_ecef(&site), rot * v)
    };
    let canopy = |ts: f64| path.canopy(ts);
    let open_sky = |_t: f64| 0.0;
    let base_pos = site;
    let base_at = move |_t: Epoch| (base_pos, Vector3::zeros());
    let rover = LowCost {
        name: "ROVER",
        at: &rover_at,
        canopy: &canopy,
        clock: (0.0, 0.0),
        span: (start, start + Duration::from_seconds(SPAN_S), 1.0),
        bands: 1,
        mask_deg: 5.0,
        atmosphere: None,
        code_bias: [0.0; 2],
        gps_l1: GpsL1::CaAsP,
        impair: Some(rover_impairments()),
        profile: Profile {
            glonass_icb: (0.003, 0.12),
            ..profile()
        },
    };
    let base = LowCost {
        name: "BASE",
        at: &base_at,
        canopy: &open_sky,
        span: (base_start, base_end, 1.0),
        impair: Some(base_impairments()),
        profile: Profile {
            half_s: [(0.5, 3.0), (0.5, 3.0)],
            ..profile()
        },
        ..rover
    };
    let (rtext, rstats) = receiver::simulate(&rover, &eph, &klob, &rng.fork(1), &|_| true);
    let n_base = BASE_SPAN_S as usize + 1;
    // The real base's UBX log: 763 epochs over 3,684 s, gaps 1–38 s (median 4); its RTCM:
    // 1,721 epochs, gaps 1–14 s (median 2).
    let ubx_keep = kept(
        n_base,
        &[0.75, 0.93],
        &[
            (0.18, (1, 1)),
            (0.64, (2, 5)),
            (0.88, (6, 10)),
            (0.99, (11, 20)),
            (1.0, (21, 38)),
        ],
        &mut rng.fork(3),
    );
    let rtcm_keep = kept(
        n_base,
        &[0.5, 0.75, 0.88],
        &[
            (0.45, (1, 1)),
            (0.95, (2, 5)),
            (0.998, (6, 10)),
            (1.0, (11, 14)),
        ],
        &mut rng.fork(5),
    );
    let either = |k: usize| ubx_keep[k] || rtcm_keep[k];
    let (btext, bstats) = receiver::simulate(&base, &eph, &klob, &rng.fork(2), &either);
    let rover_rinex = write(dir, "rover_rinex.obs", &rtext)?;
    let base_rinex = write(dir, "base_rinex.obs", &btext)?;
    let rover_obs = ObsFile::read(&rover_rinex)?;
    let (ubx, _) = gnss::raw::ubx_write::ubx_from_obs(&rover_obs);
    write_bytes(dir, "rover.ubx", &ubx)?;
    let base_obs = ObsFile::read(&base_rinex)?;
    // The base file's epochs are those either stream kept, in order.
    let logged: Vec<usize> = (0..n_base).filter(|&k| either(k)).collect();
    let in_ubx = |i: usize| logged.get(i).is_some_and(|&k| ubx_keep[k]);
    let in_rtcm = |i: usize| logged.get(i).is_some_and(|&k| rtcm_keep[k]);
    write_bytes(
        dir,
        "base.ubx",
        &mixed_base_log(&base_obs, base_pos, &in_ubx, &in_rtcm),
    )?;
    write(
        dir,
        "truth_trajectory.csv",
        &truth_at_instants(&rstats.instants, &rover_at),
    )?;
    write(dir, "ppk.toml", WALK_TOML)?;
    let count = |m: &[bool]| logged.iter().filter(|&&k| m[k]).count();
    let walk = FieldWalk {
        base_logged: (count(&ubx_keep), count(&rtcm_keep), logged.len()),
        rover: rstats,
        base: bstats,
        base_position: base_pos,
        still_share: path.still_share(SPAN_S),
    };
    write(dir, "README.txt", &text(&walk))?;
    Ok(walk)
}

/// The `ppk --config` file of the walk: the logs as they are, the base position from the
/// base log's RTCM 1005.
const WALK_TOML: &str =
    "# ppkat ppk --config ppk.toml: the simulated M8P stake-out walk (see README.txt)\n\
rover = \"rover.ubx\"\n\
base = \"base.ubx\"\n\
nav = [\"nav.rnx\"]\n\
systems = \"G,R\"\n\
frequencies = 1\n\
out = \"ppk.pos\"\n";

/// What the walk's receivers hold.
pub fn text(w: &FieldWalk) -> String {
    let mut s = String::from(
        "Simulated low-cost walk (ppkat simulate --builtin lowcost), shaped on the fingerprint of a\n\
         real u-blox M8P walk: a rover on a pole staking out points 3-30 m from a base of the same\n\
         kind, 20 min at 1 Hz, GPS and GLONASS L1, half the points under trees. Both receivers\n\
         carry what the real ones were measured to do: time tags 9-13 ms off GPS time, wandering\n\
         clocks, short arcs, phase jumps without a flag, slowly varying code errors with\n\
         excursions of metres, heavy-tailed Doppler. Compare with the real walk:\n\
         fingerprint.py --compare shared/data/lowcost-fingerprint/real_walk.json (its README).\n\
         Process: ppkat ppk --config ppk.toml; check: posstat.py ppk.pos --truth-sim truth_trajectory.csv\n\n",
    );
    let r = &w.rover;
    let _ = writeln!(
        s,
        "rover: {} epochs, {} satellites a median epoch, C/N0 p10/p50/p90 {:.0}/{:.0}/{:.0} dB-Hz; standing {:.0} % of the time; {} re-acquisitions, {} phase jumps the receiver did not flag",
        r.epochs,
        r.median_sats(),
        r.cn0_percentile(10.0),
        r.cn0_percentile(50.0),
        r.cn0_percentile(90.0),
        100.0 * w.still_share,
        r.reacquisitions,
        r.unflagged_slips
    );
    let (ubx, rtcm, either) = w.base_logged;
    let p = w.base_position.0;
    let _ = writeln!(
        s,
        "base: {either} epochs logged over 3,683 s ({ubx} as UBX RXM-RAWX, {rtcm} as RTCM 3 MSM7); position (ARP, RTCM 1005) {:.4} {:.4} {:.4}",
        p.x, p.y, p.z
    );
    s
}
