//! `simulate --builtin lowcost`: the test bench of low-cost receivers as drones and
//! surveyors fly and walk them, with exact truth, not to be easy:
//!
//! - `walk/` ([`fieldwalk`]): a u-blox M8P-like rover on a pole staking out points 3–30 m
//!   from a base of the same kind, 20 min at 1 Hz, GPS and GLONASS L1, both receivers carrying
//!   the impairments ([`impair`]) measured on a real pair (`shared/data/lowcost-fingerprint`);
//!   the base's log mixes UBX, RTCM 3 and NMEA, its UBX and RTCM epochs each with gaps.
//! - `walk-open/`: the kinder walk shaped after issue 47's words: a rover walking a river
//!   trail, 20 min at 1 Hz, GPS, GLONASS and QZSS L1, under trees for half the walk (C/N0
//!   falling, losses of lock, half cycles that clear after some seconds, multipath), against
//!   a base a few hundred metres away whose log lost epochs (gaps of 1–39 s); GLONASS
//!   inter-channel biases differ between the two receivers.
//! - `drone/` ([`drone`]): the DJI Phantom 4 RTK-like flight.
//!
//! Each folder holds the logs, `nav.rnx` (the synthetic constellation), `ppk.toml` (the
//! `ppk --config` file that processes it), `truth_trajectory.csv` (the antenna at the true
//! reception time of every rover epoch; the columns of the other flights), the RINEX of each
//! receiver (`*_rinex.obs`, the same observations for other tools) and `README.txt` (what was
//! simulated, with its figures).
//!
//! Enters: the output folder and a seed ([`SEED`]: the bench's own files). Leaves: those
//! files and a [`LowCostReport`]. Uses [`receiver`] (the tracking model), [`impair`],
//! [`stakeout`] and [`walk`] (the paths), the constellation and the raw-log writers of `gnss`.

pub mod drone;
pub mod fieldwalk;
pub mod impair;
pub mod receiver;
pub mod stakeout;
pub mod walk;

use super::constellation::{navigation_text_with, GpsLayout};
use super::error::SimError;
use super::io::{write, write_bytes};
use super::rng::Rng;
use gnss::frame::{Ecef, Enu, Geodetic};
use gnss::orbit::Ephemerides;
use gnss::raw::rtcm::message_number;
use gnss::raw::rtcm_msm::msm_kind;
use gnss::rinex::nav::NavFile;
use gnss::rinex::ObsFile;
use gnss::sv::Constellation;
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;
use receiver::{GpsL1, LowCost, Profile, TrackStats};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What the bench wrote.
#[derive(Clone, Debug)]
pub struct LowCostReport {
    /// The walk's folder (the walk shaped on the measured fingerprint).
    pub walk: PathBuf,
    /// What the walk holds.
    pub field: fieldwalk::FieldWalk,
    /// The open-sky walk's folder (`walk-open`: the river trail, kinder than the receivers
    /// measured since).
    pub open_walk: PathBuf,
    /// The rover of the open-sky walk.
    pub walk_rover: TrackStats,
    /// The base of the open-sky walk.
    pub walk_base: TrackStats,
    /// The open-sky walk's base position (ARP), ECEF.
    pub walk_base_position: Ecef,
    /// The drone's folder.
    pub drone: PathBuf,
    /// What the drone's simulation holds.
    pub drone_report: drone::DroneReport,
}

impl std::fmt::Display for LowCostReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "walk → {}\n{}",
            self.walk.display(),
            fieldwalk::text(&self.field)
        )?;
        write!(f, "{}", walk_summary(self))?;
        write!(
            f,
            "drone → {}\n{}",
            self.drone.display(),
            drone_text(&self.drone_report)
        )
    }
}

/// The walk's site (Kyoto, where the QZSS satellites are high) and its start (GPST).
const WALK_SITE: (f64, f64, f64) = (35.02, 135.77, 52.0);
const WALK_START: &str = "2025-05-14T02:10:00";
/// The walk's length, seconds.
const WALK_S: f64 = 1200.0;
/// The walk's base, ENU metres from the site.
const WALK_BASE: [f64; 3] = [40.0, 210.0, 3.0];

/// What a walk's receivers do with half cycles: how long (s) a GPS/QZSS arc's half cycle
/// stays unresolved, and the chance that its phase is half a cycle off meanwhile. The bench's
/// walk is shaped after the real one ([`WalkHalfCycles::default`]); a test may make the half
/// cycles longer and always off, to show what they do to a fix.
#[derive(Clone, Copy, Debug)]
pub struct WalkHalfCycles {
    /// Seconds unresolved (uniform in this range), GPS and QZSS.
    pub gps_s: (f64, f64),
    /// The chance that the phase is half a cycle off while unresolved.
    pub off_probability: f64,
}

impl Default for WalkHalfCycles {
    /// 3–13 s, half of them off: 9.6 % of GPS phases flagged (the real walk: 8 %).
    fn default() -> Self {
        WalkHalfCycles {
            gps_s: (3.0, 13.0),
            off_probability: 0.5,
        }
    }
}

/// The M8P-like rover: C/N0 30/43/51 dB-Hz at p10/p50/p90 over the walk, half cycles on
/// 6–9 % of the phases.
fn walk_rover_profile(half: &WalkHalfCycles) -> Profile {
    Profile {
        half_s: [half.gps_s, (4.0, 19.0)],
        half_offset_probability: half.off_probability,
        phase: (0.0015, 0.004, 3.0),
        unflagged_slip_rate: 0.01,
        canopy_db: (7.0, 4.0, 6.0),
        cn0: (36.0, 53.0),
        lock: (25.0, 28.0),
        code: (0.3, 0.6, 15.0),
        doppler: 0.06,
        glonass_icb: (0.011, 0.28),
    }
}

/// The base: the same receiver type under open sky, its GLONASS biases of its own.
fn walk_base_profile(half: &WalkHalfCycles) -> Profile {
    Profile {
        glonass_icb: (-0.007, -0.17),
        ..walk_rover_profile(half)
    }
}

/// Which epochs the base's log kept: runs and gaps of 1–39 s (the real log: 763 epochs
/// over 3,683 s).
fn base_log_gaps(n: usize, rng: &mut Rng) -> Vec<bool> {
    let mut keep = vec![false; n];
    let mut k = 0;
    while k < n {
        keep[k] = true;
        let u = rng.uniform();
        k += if u < 0.6 {
            1
        } else if u < 0.85 {
            rng.range(2.0, 7.0) as usize
        } else {
            rng.range(7.0, 40.0) as usize
        };
    }
    keep
}

/// The seed of the bench's own files (`simulate --builtin lowcost` without `--seed`).
pub const SEED: u64 = 47;

/// Run the bench into `dir` (`dir/walk/`, `dir/walk-open/`, `dir/drone/`); another `seed`
/// draws another realisation of each.
pub fn run(dir: &Path, seed: u64) -> Result<LowCostReport, SimError> {
    let rng = Rng::new(seed);
    let walk_dir = dir.join("walk");
    let field = fieldwalk::walk(&walk_dir, &rng.fork(3))?;
    let open_walk = dir.join("walk-open");
    let (walk_rover, walk_base, walk_base_position) =
        walk(&open_walk, &rng.fork(1), &WalkHalfCycles::default())?;
    let drone_dir = dir.join("drone");
    let drone_report = drone::drone(&drone_dir, &rng.fork(2))?;
    write(&drone_dir, "README.txt", &drone_text(&drone_report))?;
    Ok(LowCostReport {
        walk: walk_dir,
        field,
        open_walk,
        walk_rover,
        walk_base,
        walk_base_position,
        drone: drone_dir,
        drone_report,
    })
}

pub(crate) fn gpst(s: &str) -> Result<Epoch, SimError> {
    Epoch::from_gregorian_str(&format!("{s} GPST")).map_err(|e| SimError::Key {
        key: "start",
        what: e.to_string(),
    })
}

/// The constellation over `[start, end]`, with the GPS satellites of `gps`, written to
/// `dir/nav.rnx` and read back.
pub(crate) fn constellation(
    dir: &Path,
    (start, end): (Epoch, Epoch),
    seed: u64,
    systems: &[Constellation],
    gps: GpsLayout,
) -> Result<(NavFile, Ephemerides), SimError> {
    nav_read_back(dir, &navigation_text_with(start, end, seed, systems, gps))
}

/// Navigation `text` written to `dir/nav.rnx` and read back, as a receiver would see it.
pub(crate) fn nav_read_back(dir: &Path, text: &str) -> Result<(NavFile, Ephemerides), SimError> {
    let path = write(dir, "nav.rnx", text)?;
    let nav = NavFile::read(&path)?;
    let eph = Ephemerides::from_nav(std::slice::from_ref(&nav));
    Ok((nav, eph))
}

/// The walk shaped on the measured fingerprint (`walk/` of [`run`]) drawn from `seed`, into
/// `dir`: what it holds.
pub fn field_walk_into(dir: &Path, seed: u64) -> Result<fieldwalk::FieldWalk, SimError> {
    fieldwalk::walk(dir, &Rng::new(seed).fork(3))
}

/// The open-sky walk with its half cycles as `half` says, into `dir`: rover and base
/// simulated, logs, truth and the configuration written; what the rover and base hold, and
/// the base position.
pub fn walk_into(
    dir: &Path,
    seed: u64,
    half: &WalkHalfCycles,
) -> Result<(TrackStats, TrackStats, Ecef), SimError> {
    walk(dir, &Rng::new(seed).fork(1), half)
}

/// The walk: rover and base simulated, logs, truth and the configuration written.
fn walk(
    dir: &Path,
    rng: &Rng,
    half: &WalkHalfCycles,
) -> Result<(TrackStats, TrackStats, Ecef), SimError> {
    let start = gpst(WALK_START)?;
    let site = Geodetic::from_degrees(WALK_SITE.0, WALK_SITE.1, WALK_SITE.2).to_ecef();
    let systems = [
        Constellation::Gps,
        Constellation::Glonass,
        Constellation::Qzss,
    ];
    let base_start = start - Duration::from_seconds(1500.0);
    let base_end = base_start + Duration::from_seconds(3683.0);
    let (nav, eph) = constellation(
        dir,
        (base_start, base_end),
        47,
        &systems,
        GpsLayout::Baseline24,
    )?;
    let klob = nav.gps_iono.unwrap_or_default();
    let enu = |v: Vector3<f64>| Enu(v).to_ecef(&site);
    let rover_at = |t: Epoch| {
        let (p, v) = walk::at((t - start).to_seconds());
        let r = gnss::frame::enu_rotation(&site.to_geodetic()).transpose();
        (enu(p), r * v)
    };
    let base_pos = enu(Vector3::from(WALK_BASE));
    let base_at = move |_t: Epoch| (base_pos, Vector3::zeros());
    let rover = LowCost {
        name: "ROVER",
        at: &rover_at,
        canopy: &walk::canopy,
        clock: (2.4e-4, 2.0e-8),
        span: (start, start + Duration::from_seconds(WALK_S), 1.0),
        bands: 1,
        mask_deg: 5.0,
        atmosphere: None,
        code_bias: [0.0; 2],
        gps_l1: GpsL1::CaAsP,
        impair: None,
        profile: walk_rover_profile(half),
    };
    let open_sky = |_t: f64| 0.0;
    let base = LowCost {
        name: "BASE",
        at: &base_at,
        canopy: &open_sky,
        clock: (-3.1e-4, -1.5e-8),
        span: (base_start, base_end, 1.0),
        bands: 1,
        mask_deg: 5.0,
        atmosphere: None,
        code_bias: [0.0; 2],
        gps_l1: GpsL1::CaAsP,
        impair: None,
        profile: walk_base_profile(half),
    };
    let (rtext, rstats) = receiver::simulate(&rover, &eph, &klob, &rng.fork(1), &|_| true);
    let n_base = 3684;
    let keep = base_log_gaps(n_base, &mut rng.fork(3));
    let (btext, bstats) = receiver::simulate(&base, &eph, &klob, &rng.fork(2), &|k| keep[k]);
    let rover_rinex = write(dir, "rover_rinex.obs", &rtext)?;
    let base_rinex = write(dir, "base_rinex.obs", &btext)?;
    let rover_obs = ObsFile::read(&rover_rinex)?;
    let (ubx, _) = gnss::raw::ubx_write::ubx_from_obs(&rover_obs);
    write_bytes(dir, "rover.ubx", &ubx)?;
    let base_obs = ObsFile::read(&base_rinex)?;
    let all = |_: usize| true;
    write_bytes(
        dir,
        "base.ubx",
        &mixed_base_log(&base_obs, base_pos, &all, &all),
    )?;
    let clock = rover.clock;
    write(
        dir,
        "truth_trajectory.csv",
        &truth_csv(start, WALK_S, 1.0, clock, &rover_at),
    )?;
    write(dir, "ppk.toml", WALK_TOML)?;
    let report = walk_text(&rstats, &bstats, base_pos);
    write(dir, "README.txt", &report)?;
    Ok((rstats, bstats, base_pos))
}

/// The `ppk --config` file of the walk: the logs as they are, the base position from the
/// base log's RTCM 1005.
const WALK_TOML: &str = "# ppkat ppk --config ppk.toml: the simulated M8P walk (see README.txt)\n\
rover = \"rover.ubx\"\n\
base = \"base.ubx\"\n\
nav = [\"nav.rnx\"]\n\
systems = \"G,R,J\"\n\
frequencies = 1\n\
out = \"ppk.pos\"\n";

/// The base's log as a u-blox base writes it: UBX RXM-RAWX of the epochs `ubx` keeps (by
/// index in `obs`), the RTCM 3 it sends beside (1005 every ten epochs, the MSM7 of the
/// epochs `rtcm` keeps, 1230 GLONASS biases) and an NMEA GGA of each epoch either kept.
/// Lock times and phase shifts run over all the epochs of `obs`, as the receiver tracked.
pub(crate) fn mixed_base_log(
    obs: &ObsFile,
    arp: Ecef,
    ubx: &dyn Fn(usize) -> bool,
    rtcm: &dyn Fn(usize) -> bool,
) -> Vec<u8> {
    let (ubx_bytes, _) = gnss::raw::ubx_write::ubx_from_obs(obs);
    let (rtcm_bytes, _) = gnss::raw::rtcm_write::rtcm_from_obs(obs, &[]);
    let msm_groups = msm_groups(&rtcm_bytes);
    let g = arp.to_geodetic();
    let mut out = gnss::raw::rtcm_write::station_1005([arp.0.x, arp.0.y, arp.0.z]);
    let mut i = 0;
    let mut epoch = 0;
    while i + 8 <= ubx_bytes.len() {
        let n = u16::from_le_bytes([ubx_bytes[i + 4], ubx_bytes[i + 5]]) as usize + 8;
        let rawx = ubx_bytes[i + 2] == 0x02 && ubx_bytes[i + 3] == 0x15;
        if !rawx || ubx(epoch) {
            out.extend_from_slice(&ubx_bytes[i..i + n]);
        }
        if rawx {
            if let Some(group) = msm_groups.get(epoch).filter(|_| rtcm(epoch)) {
                group.iter().for_each(|f| out.extend_from_slice(f));
            }
            if epoch % 10 == 9 {
                out.extend(gnss::raw::rtcm_write::station_1005([
                    arp.0.x, arp.0.y, arp.0.z,
                ]));
                out.extend(gnss::raw::rtcm::frame(&[0x4c, 0xe0, 0, 0, 0]));
            }
            if let Some(e) = obs.epochs.get(epoch).filter(|_| ubx(epoch) || rtcm(epoch)) {
                out.extend(gga(e.time, &g));
            }
            epoch += 1;
        }
        i += n;
    }
    out
}

/// The MSM frames of an RTCM stream grouped by epoch (a group ends before an MSM of a system
/// it already has).
fn msm_groups(rtcm: &[u8]) -> Vec<Vec<&[u8]>> {
    let mut groups: Vec<Vec<&[u8]>> = Vec::new();
    let mut sys_in: Vec<Constellation> = Vec::new();
    let mut i = 0;
    while i + 6 <= rtcm.len() {
        let n = gnss::raw::rtcm::payload_len(&rtcm[i..]) + 6;
        let frame = &rtcm[i..i + n];
        if let Some((sys, _)) = msm_kind(message_number(&frame[3..])) {
            if groups.is_empty() || sys_in.contains(&sys) {
                groups.push(Vec::new());
                sys_in.clear();
            }
            sys_in.push(sys);
            if let Some(g) = groups.last_mut() {
                g.push(frame);
            }
        }
        i += n;
    }
    groups
}

/// An NMEA GGA sentence of a fixed position at `t` (GPST; GGA's UTC = GPST − 18 s).
fn gga(t: Epoch, g: &Geodetic) -> Vec<u8> {
    let utc = t - Duration::from_seconds(18.0);
    let (_, _, _, h, m, s, ns) = utc.to_gregorian(hifitime::TimeScale::GPST);
    let dm = |deg: f64| {
        let d = deg.abs().trunc();
        (d, (deg.abs() - d) * 60.0)
    };
    let (la, lam) = dm(g.lat.to_degrees());
    let (lo, lom) = dm(g.lon.to_degrees());
    let sep = 37.5;
    let body = format!(
        "GNGGA,{h:02}{m:02}{:05.2},{la:02}{lam:08.5},{},{lo:03}{lom:08.5},{},1,12,0.8,{:.3},M,{sep:.3},M,,",
        s as f64 + ns as f64 * 1e-9,
        if g.lat >= 0.0 { 'N' } else { 'S' },
        if g.lon >= 0.0 { 'E' } else { 'W' },
        g.h - sep
    );
    let sum = body.bytes().fold(0u8, |a, c| a ^ c);
    format!("${body}*{sum:02X}\r\n").into_bytes()
}

/// The antenna at the true reception time of every epoch of a receiver tagged every `dt`
/// seconds from `start` for `span` seconds with clock `(offset, drift)`: week, tow, ECEF
/// position and velocity, zero attitude.
pub(crate) fn truth_csv(
    start: Epoch,
    span: f64,
    dt: f64,
    clock: (f64, f64),
    at: &dyn Fn(Epoch) -> (Ecef, Vector3<f64>),
) -> String {
    let n = (span / dt).floor() as usize;
    let instants: Vec<Epoch> = (0..=n)
        .map(|k| {
            let tag = k as f64 * dt;
            start + Duration::from_seconds(tag - (clock.0 + clock.1 * tag))
        })
        .collect();
    truth_at_instants(&instants, at)
}

/// The antenna at each true reception time of `instants` (see [`truth_csv`]).
pub(crate) fn truth_at_instants(
    instants: &[Epoch],
    at: &dyn Fn(Epoch) -> (Ecef, Vector3<f64>),
) -> String {
    let mut s = String::from("# antenna phase centre at the true reception time of each rover epoch (receiver tag − clock offset), GPST; ECEF metres; velocity m/s; attitude degrees (not simulated: 0)\nweek,tow,x,y,z,vx,vy,vz,roll,pitch,yaw\n");
    for &t in instants {
        let (p, v) = at(t);
        let (w, tow) = gnss::time::week_tow(t);
        let _ = writeln!(
            s,
            "{w},{tow:.9},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},0,0,0",
            p.0.x, p.0.y, p.0.z, v.x, v.y, v.z
        );
    }
    s
}

/// What the walk's receivers hold, against the real case's figures.
fn walk_text(r: &TrackStats, b: &TrackStats, base: Ecef) -> String {
    let mut s = String::from("Simulated low-cost walk (ppkat simulate --builtin lowcost): a u-blox M8P-like rover\nwalking a river trail 20 min at 1 Hz, GPS/GLONASS/QZSS L1, against a base of the same kind.\nProcess: ppkat ppk --config ppk.toml; check: posstat.py ppk.pos --truth-sim truth_trajectory.csv\n\n");
    let _ = writeln!(
        s,
        "rover: {} epochs, {} satellites a median epoch, C/N0 p10/p50/p90 {:.0}/{:.0}/{:.0} dB-Hz (real: 19, 30/43/51)",
        r.epochs,
        r.median_sats(),
        r.cn0_percentile(10.0),
        r.cn0_percentile(50.0),
        r.cn0_percentile(90.0)
    );
    let _ = writeln!(
        s,
        "rover: unresolved half cycles on {:.1} % of GPS, {:.1} % of GLONASS, {:.1} % of QZSS phases (real: 8 % GPS, 6 % GLONASS); {} re-acquisitions, {} slips the receiver did not flag",
        100.0 * r.half_share(Constellation::Gps),
        100.0 * r.half_share(Constellation::Glonass),
        100.0 * r.half_share(Constellation::Qzss),
        r.reacquisitions,
        r.unflagged_slips
    );
    let _ = writeln!(
        s,
        "base: {} epochs logged over 3,683 s (real: 763), gaps of 1-39 s; position (ARP, RTCM 1005) {:.4} {:.4} {:.4}",
        b.epochs, base.0.x, base.0.y, base.0.z
    );
    s
}

/// What the drone's receivers and log hold.
fn drone_text(d: &drone::DroneReport) -> String {
    let r = &d.rover;
    format!(
        "Simulated DJI Phantom 4 RTK-like flight (ppkat simulate --builtin lowcost): {:.0} s, RTCM 3\n\
         MSM7 at 5 Hz (GPS, GLONASS, Galileo L1/L2) in PPKRAW.bin beside Timestamp.MRK, against a\n\
         CORS RINEX (base.obs, 1 Hz) 1.7 km away. The log opens with {} stale GPS ephemerides of\n\
         weeks 2018, 2019 and 2022 before the current ones (week 2024): ppkat dates it by the\n\
         consensus of the current ones, with no hint.\n\
         Process: ppkat ppk --config ppk.toml; ppkat exposures --mrk Timestamp.MRK --trajectory ppk.pos;\n\
         check: posstat.py ppk.pos --truth-sim truth_trajectory.csv\n\n\
         rover: {} epochs, C/N0 p10/p50/p90 {:.0}/{:.0}/{:.0} dB-Hz, unresolved half cycles on {:.1} % of GPS phases\n\
         {} exposures; CORS at {:.4} {:.4} {:.4} (ECEF)\n",
        d.duration,
        d.stale,
        r.epochs,
        r.cn0_percentile(10.0),
        r.cn0_percentile(50.0),
        r.cn0_percentile(90.0),
        100.0 * r.half_share(Constellation::Gps),
        d.exposures,
        d.base_position.0.x,
        d.base_position.0.y,
        d.base_position.0.z
    )
}

/// The open-sky walk's figures for the command's summary.
fn walk_summary(r: &LowCostReport) -> String {
    format!(
        "walk-open → {}\n{}",
        r.open_walk.display(),
        walk_text(&r.walk_rover, &r.walk_base, r.walk_base_position)
    )
}
