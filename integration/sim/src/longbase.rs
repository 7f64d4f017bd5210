//! `long-baseline`: two static geodetic receivers 250 km apart observing GPS L1/L2 every 30 s
//! for 24 h (31 GPS satellites, as flew in 2024: [`GpsLayout::Operational31`]), with what the
//! broadcast models leave out at that distance: an ionosphere that differs between the two
//! ends (a north–south gradient on top of Klobuchar's own, which follows its daily cycle, and
//! travelling disturbances of a few percent), a wet troposphere of its own at each station (a
//! random walk about an offset, and north/east gradients), and receivers of different types
//! whose code biases do not cancel (the base tracks GPS C/A, the rover P(Y): each satellite's
//! C1 − P1 bias stays in the double differences, as when a C1 file meets a P1 file), and a
//! navigation file that, like merged daily files, also holds sets of an older upload metres
//! off, and for one satellite only such sets (issue 49). The truth is exact; the folder is
//! processed by `ppkat ppk --config ppk.toml` like the other benches. The same pair with
//! Galileo E1/E5a beside GPS (same atmosphere, same receivers) is written to `gps-galileo/`.
//!
//! Enters: the output folder and a seed. Leaves, in the folder and in `gps-galileo/`:
//! `base.obs`, `rover.obs`, `nav.rnx`, `ppk.toml`, `truth_trajectory.csv` (the static rover
//! at every epoch), `truth.toml` (both positions, the baseline and the atmosphere simulated)
//! and `README.txt`.

use super::constellation::{
    navigation_text_with, off_gps_records, stale_gps_records, without_gps, GpsLayout,
};
use super::error::SimError;
use super::io::write;
use super::lowcost::receiver::{self, GpsL1, LowCost, Profile, TrackStats};
use super::lowcost::{gpst, nav_read_back, truth_csv};
use super::rng::Rng;
use gnss::frame::{Ecef, Geodetic};
use gnss::sv::{Constellation, Sv};
use hifitime::{Duration, Epoch};
use nalgebra::Vector3;
use std::path::Path;

/// The first epoch (GPST) and the span and interval, seconds.
const START: &str = "2024-03-20T00:00:00";
const SPAN_S: f64 = 86400.0;
const INTERVAL_S: f64 = 30.0;
/// The base and the rover (latitude, longitude degrees, ellipsoidal height m): 250 km apart,
/// the rover to the north-east.
const BASE: (f64, f64, f64) = (46.0, 7.0, 520.0);
const ROVER: (f64, f64, f64) = (47.0787, 9.8618, 710.0);
/// The ionosphere's north–south gradient on top of Klobuchar's: its factor grows by this
/// much per degree of latitude of the pierce point north of the base.
const IONO_GRADIENT_PER_DEG: f64 = 0.06;
/// Travelling disturbances: amplitude (share of the delay), period (s), wavelength (km).
const TID: (f64, f64, f64) = (0.03, 1800.0, 300.0);
/// The wet troposphere the model leaves out at each station: offset of the zenith delay (m),
/// its random walk (m per √hour), north and east gradients (m).
const TROPO_BASE: (f64, f64, [f64; 2]) = (0.02, 0.008, [0.0006, -0.0003]);
const TROPO_ROVER: (f64, f64, [f64; 2]) = (-0.03, 0.012, [-0.0004, 0.0008]);
/// Stale ephemerides of an older upload, as merged daily navigation files carry them: one
/// GPS satellite in this many gets a set at every odd hour, this far (m) along its track
/// from the truth (see [`stale_gps_records`]).
const STALE_EVERY: usize = 4;
const STALE_ALONG_TRACK_M: f64 = 8.0;
/// A GPS satellite whose every set in the navigation file is of a stale upload, this far (m)
/// along its track from the truth, with no fresher set to replace it (BELL–EBRE's PRN 21).
/// It is also one of the every-`STALE_EVERY`-th satellites: its odd-hour sets lie as far off.
const OFF_PRN: u8 = 5;
const OFF_ALONG_TRACK_M: f64 = 8.0;
/// Code biases of the two receiver types on L1 and L2, metres.
const BIAS_BASE: [f64; 2] = [0.0, -0.45];
const BIAS_ROVER: [f64; 2] = [0.3, 1.10];

/// What was simulated.
#[derive(Clone, Debug)]
pub struct LongBaselineReport {
    /// The rover's tracking.
    pub rover: TrackStats,
    /// The base's tracking.
    pub base: TrackStats,
    /// The base and rover antenna positions.
    pub positions: [Ecef; 2],
    /// The baseline, km.
    pub baseline_km: f64,
    /// Records of an older upload in `nav.rnx` (stale by 8 m), all to be passed over.
    pub stale_records: usize,
}

/// A geodetic receiver: open sky, low noise, no half cycles, no unflagged slips.
fn geodetic() -> Profile {
    Profile {
        cn0: (38.0, 51.0),
        canopy_db: (0.0, 0.0, 1.0),
        lock: (26.0, 29.0),
        half_s: [(0.0, 0.0), (0.0, 0.0)],
        half_offset_probability: 0.0,
        unflagged_slip_rate: 0.0,
        code: (0.2, 0.3, 60.0),
        phase: (0.0012, 0.002, 30.0),
        doppler: 0.02,
        glonass_icb: (0.0, 0.0),
    }
}

/// The zenith wet delay the model leaves out at a station, every interval of the day: an
/// offset plus a random walk.
fn zenith_walk(offset: f64, per_sqrt_hour: f64, rng: &mut Rng) -> Vec<f64> {
    let n = (SPAN_S / INTERVAL_S) as usize + 2;
    let step = per_sqrt_hour * (INTERVAL_S / 3600.0).sqrt();
    let mut z = offset;
    (0..n)
        .map(|_| {
            z += step * rng.normal();
            z
        })
        .collect()
}

/// The atmosphere beyond the models at a station: (ionosphere factor, extra troposphere m)
/// for a satellite at (azimuth, elevation) at `t`.
fn atmosphere(
    station: Geodetic,
    zwd: Vec<f64>,
    gradients: [f64; 2],
    start: Epoch,
) -> impl Fn(Epoch, f64, f64) -> (f64, f64) {
    move |t, az, el| {
        // The pierce point at 350 km, on a flat-earth approximation (enough for a gradient).
        let reach_km = 350.0 / el.tan().max(0.2);
        let ipp_lat = station.lat.to_degrees() + reach_km * az.cos() / 111.2;
        let ipp_lon = station.lon.to_degrees() + reach_km * az.sin() / (111.2 * 0.69);
        let ts = (t - start).to_seconds();
        let phase =
            2.0 * std::f64::consts::PI * (ts / TID.1 + (ipp_lat * 111.2 + ipp_lon * 77.0) / TID.2);
        let iono = 1.0 + IONO_GRADIENT_PER_DEG * (ipp_lat - BASE.0) + TID.0 * phase.sin();
        let k = ((ts / INTERVAL_S).max(0.0) as usize).min(zwd.len() - 1);
        let (se, te) = (el.sin(), el.tan());
        let wet = zwd[k] / (se + 0.0003);
        let grad = (gradients[0] * az.cos() + gradients[1] * az.sin()) / (se * te + 0.0032);
        (iono, wet + grad)
    }
}

/// The systems of a variant, their signals and the `systems` of its `ppk.toml`.
#[derive(Clone, Copy, Debug)]
struct Variant {
    systems: &'static [Constellation],
    signals: &'static str,
    option: &'static str,
    /// With the faults of [`super::longbase_faults`].
    faults: bool,
}

/// GPS L1/L2, the bench's own.
const GPS: Variant = Variant {
    systems: &[Constellation::Gps],
    signals: "GPS L1/L2",
    option: "G",
    faults: false,
};

/// GPS L1/L2 with unflagged slips and a bad orbit ([`super::longbase_faults`]).
const GPS_FAULTS: Variant = Variant {
    systems: &[Constellation::Gps],
    signals: "GPS L1/L2 with unflagged slips and a bad orbit",
    option: "G",
    faults: true,
};

/// GPS L1/L2 with Galileo E1/E5a.
const GPS_GALILEO: Variant = Variant {
    systems: &[Constellation::Gps, Constellation::Galileo],
    signals: "GPS L1/L2 and Galileo E1/E5a",
    option: "G,E",
    faults: false,
};

/// The seed of the bench's own files (`simulate --builtin long-baseline` without `--seed`).
pub const SEED: u64 = 49;

/// Simulate the pair into `dir` (GPS), `dir/gps-galileo` (GPS and Galileo) and `dir/faults`
/// (GPS with unflagged slips and a bad orbit, [`super::longbase_faults`]); the report is the
/// GPS one's.
pub fn run(dir: &Path, seed: u64) -> Result<LongBaselineReport, SimError> {
    simulate_variant(&dir.join("gps-galileo"), seed, GPS_GALILEO)?;
    simulate_variant(&dir.join("faults"), seed, GPS_FAULTS)?;
    simulate_variant(dir, seed, GPS)
}

/// Simulate the pair observing the systems of `v` into `dir`.
fn simulate_variant(dir: &Path, seed: u64, v: Variant) -> Result<LongBaselineReport, SimError> {
    let rng = Rng::new(seed);
    let start = gpst(START)?;
    let end = start + Duration::from_seconds(SPAN_S);
    // The receivers observe the true orbits (`eph`); the navigation file processed, written
    // over it below, also holds an older upload's sets.
    let fresh = navigation_text_with(start, end, seed, v.systems, GpsLayout::Operational31);
    let (nav, eph) = nav_read_back(dir, &fresh)?;
    let (stale, stale_records) = stale_gps_records(
        (start, end),
        seed,
        GpsLayout::Operational31,
        STALE_EVERY,
        STALE_ALONG_TRACK_M,
    );
    let off = off_gps_records(
        (start, end),
        seed,
        GpsLayout::Operational31,
        OFF_PRN,
        OFF_ALONG_TRACK_M,
    );
    let mut nav_text = without_gps(&fresh, OFF_PRN) + &off + &stale;
    if v.faults {
        nav_text = super::longbase_faults::bad_orbit(
            &nav_text,
            (start, end),
            seed,
            GpsLayout::Operational31,
        );
    }
    write(dir, "nav.rnx", &nav_text)?;
    let klob = nav.gps_iono.unwrap_or_default();
    let geo = |(lat, lon, h): (f64, f64, f64)| Geodetic::from_degrees(lat, lon, h);
    let (gb, gr) = (geo(BASE), geo(ROVER));
    let (pb, pr) = (gb.to_ecef(), gr.to_ecef());
    let still = |p: Ecef| move |_: Epoch| (p, Vector3::zeros());
    let (base_at, rover_at) = (still(pb), still(pr));
    let open = |_: f64| 0.0;
    let mut r = rng.fork(3);
    let base_atm = atmosphere(
        gb,
        zenith_walk(TROPO_BASE.0, TROPO_BASE.1, &mut r),
        TROPO_BASE.2,
        start,
    );
    let rover_atm = atmosphere(
        gr,
        zenith_walk(TROPO_ROVER.0, TROPO_ROVER.1, &mut r),
        TROPO_ROVER.2,
        start,
    );
    let base = LowCost {
        name: "BASE",
        at: &base_at,
        canopy: &open,
        clock: (-3.0e-5, 0.0),
        span: (start, end, INTERVAL_S),
        bands: 2,
        mask_deg: 5.0,
        profile: geodetic(),
        impair: None,
        atmosphere: Some(&base_atm),
        code_bias: BIAS_BASE,
        gps_l1: GpsL1::Ca,
    };
    let rover = LowCost {
        name: "ROVR",
        at: &rover_at,
        clock: (2.0e-4, 1.0e-9),
        atmosphere: Some(&rover_atm),
        code_bias: BIAS_ROVER,
        gps_l1: GpsL1::P,
        ..base
    };
    let (btext, bstats) = receiver::simulate(&base, &eph, &klob, &rng.fork(1), &|_| true);
    let (rtext, rstats) = receiver::simulate(&rover, &eph, &klob, &rng.fork(2), &|_| true);
    write(dir, "base.obs", &btext)?;
    let rtext = if v.faults {
        super::longbase_faults::slips(&rtext).0
    } else {
        rtext
    };
    write(dir, "rover.obs", &rtext)?;
    write(
        dir,
        "truth_trajectory.csv",
        &truth_csv(start, SPAN_S, INTERVAL_S, rover.clock, &rover_at),
    )?;
    let baseline_km = (pr.0 - pb.0).norm() / 1000.0;
    write(dir, "ppk.toml", &ppk_toml(pb, v))?;
    let gps: Vec<Sv> = eph
        .satellites()
        .copied()
        .filter(|sv| sv.sys == Constellation::Gps)
        .collect();
    write(dir, "truth.toml", &truth_toml(pb, pr, baseline_km, &gps))?;
    let report = LongBaselineReport {
        rover: rstats,
        base: bstats,
        positions: [pb, pr],
        baseline_km,
        stale_records,
    };
    write(dir, "README.txt", &readme(&report, v))?;
    Ok(report)
}

fn ppk_toml(base: Ecef, v: Variant) -> String {
    format!(
        "# ppkat ppk --config ppk.toml: the 250 km pair, {}, 24 h at 30 s\nrover = \"rover.obs\"\nbase = \"base.obs\"\nnav = [\"nav.rnx\"]\nbase-pos = \"{:.4},{:.4},{:.4}\"\nsystems = \"{}\"\nout = \"ppk.pos\"\n",
        v.signals, base.0.x, base.0.y, base.0.z, v.option
    )
}

fn truth_toml(base: Ecef, rover: Ecef, km: f64, gps: &[Sv]) -> String {
    let c1_p1: Vec<String> = gps
        .iter()
        .map(|&sv| format!("G{:02} = {:.4}", sv.prn, receiver::c1_p1_bias(sv)))
        .collect();
    format!(
        "{}[c1_minus_p1]\n# each GPS satellite's C/A code minus its P(Y) code, metres: the base tracks C/A (C1C), the rover P(Y) (C1W)\n{}\n",
        truth_head(base, rover, km),
        c1_p1.join("\n")
    )
}

fn truth_head(base: Ecef, rover: Ecef, km: f64) -> String {
    format!(
        "# long-baseline truth: antenna reference points, ECEF metres\nbase = [{:.4}, {:.4}, {:.4}]\nrover = [{:.4}, {:.4}, {:.4}]\nbaseline_km = {km:.3}\niono_gradient_per_deg = {IONO_GRADIENT_PER_DEG}\ntid = [{}, {}, {}]\ntropo_base = [{}, {}, {}, {}]\ntropo_rover = [{}, {}, {}, {}]\ncode_bias_base = [{}, {}]\ncode_bias_rover = [{}, {}]\n",
        base.0.x, base.0.y, base.0.z, rover.0.x, rover.0.y, rover.0.z,
        TID.0, TID.1, TID.2,
        TROPO_BASE.0, TROPO_BASE.1, TROPO_BASE.2[0], TROPO_BASE.2[1],
        TROPO_ROVER.0, TROPO_ROVER.1, TROPO_ROVER.2[0], TROPO_ROVER.2[1],
        BIAS_BASE[0], BIAS_BASE[1], BIAS_ROVER[0], BIAS_ROVER[1]
    )
}

fn readme(r: &LongBaselineReport, v: Variant) -> String {
    let other = match (v.option, v.faults) {
        (_, true) => "The same pair with GPS alone and faults its σ do not know of: at epochs 960, 1680 and 2400 (08:00, 14:00, 20:00) the rover's strongest GPS satellite slips by one cycle on L1 and on L2 with no loss-of-lock flag, and G12's 10:00 set (used 09:00–11:00) puts it 30 m along its track: no epoch may lie more than 1 m off with σ under 10 cm.",
        ("G", _) => "The same pair with Galileo E1/E5a beside GPS: gps-galileo/; with faults: faults/.",
        _ => "The same pair with GPS alone: the folder above.",
    };
    format!(
        "long-baseline: two static geodetic receivers {:.1} km apart, {} every {INTERVAL_S} s for 24 h from {START} GPST. {other}\nWhat the broadcast models leave out: an ionosphere factor growing {IONO_GRADIENT_PER_DEG} per degree of pierce-point latitude north of the base, with travelling disturbances of {} % ({} s, {} km); a zenith wet delay at each station (offsets {} m and {} m, random walks {} and {} m/√h) with north/east gradients; code biases on the first/second signal of {:?} m (base) and {:?} m (rover); the base tracks GPS C/A (C1C), the rover P(Y) (C1W), so each GPS satellite's C1 − P1 bias (σ 0.3 m, listed in truth.toml) stays in the double differences; nav.rnx also holds {} sets of an older upload (every {STALE_EVERY}th GPS satellite at odd hours, {STALE_ALONG_TRACK_M} m along track from the truth, sent before the fresh sets), as merged daily files do, and G{OFF_PRN:02}'s sets are all of a stale upload ({OFF_ALONG_TRACK_M} m along track from the truth, nothing fresher to replace them).\nEpochs: rover {}, base {}; satellites per epoch (median) {}.\nProcess: ppkat ppk --config ppk.toml; compare: posstat.py ppk.pos --truth-sim truth_trajectory.csv\n",
        r.baseline_km,
        v.signals,
        TID.0 * 100.0,
        TID.1,
        TID.2,
        TROPO_BASE.0,
        TROPO_ROVER.0,
        TROPO_BASE.1,
        TROPO_ROVER.1,
        BIAS_BASE,
        BIAS_ROVER,
        r.stale_records,
        r.rover.epochs,
        r.base.epochs,
        r.rover.median_sats(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The satellites' C1 − P1 biases are drawn once per PRN, the same at every call, and
    /// spread as the published ones (σ about 0.3 m); the base writes its GPS L1 code as C/A
    /// (C1C), the rover as P(Y) (C1W), each with the phase as L1C, and truth.toml lists
    /// every bias to 0.1 mm.
    #[test]
    fn the_base_tracks_ca_and_the_rover_p_code() {
        let biases: Vec<f64> = (1..=32u8)
            .map(|prn| receiver::c1_p1_bias(Sv::new(Constellation::Gps, prn)))
            .collect();
        let again = receiver::c1_p1_bias(Sv::new(Constellation::Gps, 7));
        assert_eq!(again, biases[6]);
        let rms = (biases.iter().map(|b| b * b).sum::<f64>() / 32.0).sqrt();
        assert!((0.2..0.45).contains(&rms), "{rms}");
        let dir = testkit::scratch_path("long-baseline");
        run(&dir, 49).unwrap();
        let types = |f: &str| {
            std::fs::read_to_string(dir.join(f))
                .unwrap()
                .lines()
                .find(|l| l.starts_with('G') && l.contains("OBS TYPES"))
                .unwrap()
                .to_string()
        };
        assert!(
            types("base.obs").contains("C1C L1C"),
            "{}",
            types("base.obs")
        );
        assert!(
            types("rover.obs").contains("C1W L1C"),
            "{}",
            types("rover.obs")
        );
        let truth = std::fs::read_to_string(dir.join("truth.toml")).unwrap();
        assert!(
            truth.contains(&format!("G07 = {:.4}", biases[6])),
            "{truth}"
        );
    }

    /// What the models leave out differs between the ends as described: the rover's
    /// ionosphere factor is larger by the gradient over the 1.08° between them (6.5 %), the
    /// disturbances move it by at most 3 %, and the wet delays start 5 cm apart at the zenith.
    #[test]
    fn the_atmosphere_differs_between_the_ends() {
        let start = gpst(START).unwrap();
        let geo = |(lat, lon, h): (f64, f64, f64)| Geodetic::from_degrees(lat, lon, h);
        let b = atmosphere(geo(BASE), vec![TROPO_BASE.0], [0.0; 2], start);
        let r = atmosphere(geo(ROVER), vec![TROPO_ROVER.0], [0.0; 2], start);
        let (mut lo, mut hi) = (f64::MAX, f64::MIN);
        for k in 0..200 {
            let t = start + Duration::from_seconds(k as f64 * 97.0);
            let (ib, zb) = b(t, 0.3, std::f64::consts::FRAC_PI_2);
            let (ir, zr) = r(t, 0.3, std::f64::consts::FRAC_PI_2);
            let d = ir - ib;
            lo = lo.min(d);
            hi = hi.max(d);
            assert!(
                ((zr - zb) - (TROPO_ROVER.0 - TROPO_BASE.0)).abs() < 1e-3,
                "{zr} {zb}"
            );
        }
        let gradient = IONO_GRADIENT_PER_DEG * (ROVER.0 - BASE.0);
        assert!((gradient - 0.065).abs() < 0.002, "{gradient}");
        assert!(lo > gradient - 2.0 * TID.0 - 1e-9 && hi < gradient + 2.0 * TID.0 + 1e-9);
        assert!(
            hi - lo > TID.0,
            "the disturbances move the difference: {lo}..{hi}"
        );
    }
}
