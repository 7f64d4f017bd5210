//! The trajectory as CSV (or as an RTKLIB `.pos`, [`write_pos`]), with the columns `../shared/tools/insstat.py` reads: GPS week and
//! second of week, latitude, longitude (degrees), ellipsoidal height (m), velocity north,
//! east, up (m/s), roll, pitch, heading (degrees, heading clockwise from north) and their
//! 1-σ columns (`sd_n_m … sd_heading_deg`). The position is the IMU's. Written atomically.
//!
//! The attitude σ: the small rotation's covariance turned into the local level frame; roll
//! and pitch σ about the heading's level axes, heading σ about the vertical (for the small
//! roll and pitch of a vehicle; near ±90° of pitch, heading and roll are not separable).

use crate::errstate::{idx, Mat};
use crate::filter::Estimate;
use crate::gnss_pos::GnssEpoch;
use crate::mech::NavState;
use common::frame::enu_rotation;
use gnss::solution::{PosFormat, PosRecord, Quality};
use hifitime::Epoch;
use nalgebra::Matrix3;
use std::io::Write;
use std::path::Path;

/// The header of [`state_columns`].
pub const STATE_HEADER: &str =
    "gpst_week,gpst_tow,lat_deg,lon_deg,h_m,vn_mps,ve_mps,vu_mps,roll_deg,pitch_deg,heading_deg";
/// The CSV header line.
pub const HEADER: &str = "gpst_week,gpst_tow,lat_deg,lon_deg,h_m,vn_mps,ve_mps,vu_mps,roll_deg,pitch_deg,heading_deg,sd_n_m,sd_e_m,sd_u_m,sd_vn_mps,sd_ve_mps,sd_vu_mps,sd_roll_deg,sd_pitch_deg,sd_heading_deg";

/// The columns of a navigation state: week, second of week, latitude, longitude, height,
/// velocity north/east/up, roll/pitch/heading (what a truth file holds too).
pub fn state_columns(t: Epoch, nav: &NavState) -> String {
    let (week, tow) = gnss::time::week_tow(t);
    let g = nav.geodetic();
    let v = enu_rotation(&g) * nav.velocity;
    let att = nav.euler();
    format!(
        "{week},{tow:.4},{:.9},{:.9},{:.4},{:.4},{:.4},{:.4},{:.5},{:.5},{:.5}",
        g.lat.to_degrees(),
        g.lon.to_degrees(),
        g.h,
        v.y,
        v.x,
        v.z,
        att.roll.to_degrees(),
        att.pitch.to_degrees(),
        att.heading.to_degrees(),
    )
}

/// The 1-σ of an estimate: north, east, up (m), velocity north, east, up (m/s), roll, pitch,
/// heading (degrees), as the CSV's `sd_…` columns hold them.
pub fn sigmas(e: &Estimate, cov: &Mat) -> [f64; 9] {
    let r = enu_rotation(&e.nav.geodetic());
    let heading = e.nav.euler().heading;
    let block = |i: usize| {
        let c: Matrix3<f64> = cov.fixed_view::<3, 3>(i, i).into_owned();
        r * c * r.transpose()
    };
    let (p, vc, a) = (block(idx::POS), block(idx::VEL), block(idx::ATT));
    let sd = |m: &Matrix3<f64>, k: usize| m[(k, k)].max(0.0).sqrt();
    // Level axes of the heading: forward (roll) and right (pitch), in east-north.
    let (sh, ch) = heading.sin_cos();
    let axis = |x: [f64; 2]| {
        let (ee, nn, en) = (a[(0, 0)], a[(1, 1)], a[(0, 1)]);
        (x[0] * x[0] * ee + x[1] * x[1] * nn + 2.0 * x[0] * x[1] * en)
            .max(0.0)
            .sqrt()
            .to_degrees()
    };
    [
        sd(&p, 1),
        sd(&p, 0),
        sd(&p, 2),
        sd(&vc, 1),
        sd(&vc, 0),
        sd(&vc, 2),
        axis([sh, ch]),
        axis([ch, -sh]),
        a[(2, 2)].max(0.0).sqrt().to_degrees(),
    ]
}

/// One row of the CSV for an estimate and its covariance.
pub fn row(t: Epoch, e: &Estimate, cov: &Mat) -> String {
    let s = sigmas(e, cov);
    format!(
        "{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.5},{:.5},{:.5}",
        state_columns(t, &e.nav),
        s[0],
        s[1],
        s[2],
        s[3],
        s[4],
        s[5],
        s[6],
        s[7],
        s[8],
    )
}

/// Write the rows to `path` atomically, after `#` comment lines.
pub fn write_csv(
    path: &Path,
    comments: &[String],
    rows: &[(Epoch, Estimate, Mat)],
) -> crate::Result<()> {
    common::atomic::write_atomic(path, |w: &mut dyn Write| {
        for c in comments {
            writeln!(w, "# {c}")?;
        }
        writeln!(w, "{HEADER}")?;
        for (t, e, c) in rows {
            writeln!(w, "{}", row(*t, e, c))?;
        }
        Ok(())
    })?;
    Ok(())
}

/// Longest time (s) a GNSS epoch's quality is carried to the rows after it in a `.pos`.
pub const QUALITY_HOLD: f64 = 2.0;

/// Write the rows to `path` as an RTKLIB `.pos` (latitude, longitude, ellipsoidal height of
/// the IMU, σ and correlations from the position covariance), atomically. `Q` is that of the
/// last GNSS epoch used (`used`, in time order) when it is at most [`QUALITY_HOLD`] s old,
/// and 5 (as single) while the IMU bridges longer; `ns` is 0 (a `.pos` of GNSS epochs holds
/// the satellites).
pub fn write_pos(
    path: &Path,
    comments: &[String],
    rows: &[(Epoch, Estimate, Mat)],
    used: &[&GnssEpoch],
) -> crate::Result<()> {
    let records: Vec<PosRecord> = rows
        .iter()
        .map(|(t, e, c)| {
            let k = used.partition_point(|g| g.time <= *t);
            let quality = k
                .checked_sub(1)
                .map(|i| used[i])
                .filter(|g| (*t - g.time).to_seconds() <= QUALITY_HOLD)
                .map_or(Quality::Single, |g| g.quality);
            PosRecord {
                time: *t,
                pos: e.nav.position,
                quality,
                nsat: 0,
                cov: c.fixed_view::<3, 3>(idx::POS, idx::POS).into_owned(),
                age: 0.0,
                ratio: 0.0,
            }
        })
        .collect();
    gnss::solution::write_pos(path, comments, &records, PosFormat::Llh)?;
    Ok(())
}
