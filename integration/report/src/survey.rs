//! The summary of a static carrier-phase run (`ppkat ppk --mode static`): the one rover
//! position with its σ, the span and epochs it rests on, its fix state and the residuals,
//! as JSON (`OUT.pos.json`, beside the `.pos`) and as report lines.
//!
//! What enters: a [`StaticSolution`] from `gnss::ppk::process`. What leaves: the JSON text
//! and the lines the `ppk` report prints.

use gnss::frame::{enu_rotation, Ecef};
use gnss::ppk::{Reference, StaticSolution};
use gnss::solution::Quality;
use gnss::time::format_ymdhms;
use nalgebra::Matrix3;
use serde_json::json;

/// The ENU covariance (m²) of a position at `pos` with ECEF covariance `cov`.
fn enu_cov(pos: &Ecef, cov: &Matrix3<f64>) -> Matrix3<f64> {
    let r = enu_rotation(&pos.to_geodetic());
    r * cov * r.transpose()
}

/// σ east, north, up (m) of a position at `pos` with ECEF covariance `cov` (m²).
pub fn enu_sigmas(pos: &Ecef, cov: &Matrix3<f64>) -> [f64; 3] {
    let c = enu_cov(pos, cov);
    [0, 1, 2].map(|i| c[(i, i)].max(0.0).sqrt())
}

/// Name of a reference point, as the CLI spells it.
pub fn refer_name(refer: Reference) -> &'static str {
    match refer {
        Reference::Arp => "arp",
        Reference::Marker => "marker",
    }
}

/// The JSON summary of a static solution: position (ECEF and geodetic), σ east/north/up,
/// ENU and ECEF covariances, fix state, span, epochs and residuals; `base_marker` is the base
/// position used.
pub fn json(
    s: &StaticSolution,
    refer: Reference,
    base_marker: &Ecef,
    heights: &georef::height::Heights,
) -> gnss::error::Result<String> {
    let g = s.pos.to_geodetic();
    let enu = enu_cov(&s.pos, &s.cov);
    let rows = |m: &Matrix3<f64>| -> Vec<[f64; 3]> {
        (0..3).map(|i| [m[(i, 0)], m[(i, 1)], m[(i, 2)]]).collect()
    };
    let spread = |sp: &gnss::ppk::Spread| json!({ "count": sp.count, "rms_m": sp.rms(), "max_abs_m": sp.max_abs });
    let v = json!({
        "program": format!("ppkat {}", env!("CARGO_PKG_VERSION")),
        "mode": "static",
        "refers_to": refer_name(refer),
        "position": {
            "ecef_m": [s.pos.0.x, s.pos.0.y, s.pos.0.z],
            "latitude_deg": g.lat.to_degrees(),
            "longitude_deg": g.lon.to_degrees(),
            "ellipsoidal_height_m": g.h,
        },
        "sigma_m": {
            "east": enu[(0, 0)].max(0.0).sqrt(),
            "north": enu[(1, 1)].max(0.0).sqrt(),
            "up": enu[(2, 2)].max(0.0).sqrt(),
        },
        "covariance_enu_m2": rows(&enu),
        "covariance_ecef_m2": rows(&s.cov),
        "quality": if s.quality == Quality::Fixed { "fixed" } else { "float" },
        "ratio": s.ratio,
        "first_epoch_gpst": format_ymdhms(s.span.0),
        "last_epoch_gpst": format_ymdhms(s.span.1),
        "epochs": s.epochs,
        "fixed_epochs": s.fixed_epochs,
        "residuals": {
            "phase": spread(&s.residuals.0),
            "code": spread(&s.residuals.1),
        },
        "base_marker_ecef_m": [base_marker.0.x, base_marker.0.y, base_marker.0.z],
    });
    let mut v = v;
    add_orthometric(&mut v["position"], &g, heights)?;
    Ok(serde_json::to_string_pretty(&v).unwrap_or_default() + "\n")
}

/// With an orthometric height model, add the orthometric height, the model and the geoid
/// undulation to a JSON position (which keeps its ellipsoidal height).
pub fn add_orthometric(
    position: &mut serde_json::Value,
    g: &gnss::frame::Geodetic,
    heights: &georef::height::Heights,
) -> gnss::error::Result<()> {
    if heights.orthometric() {
        let n = heights.undulation(g)?;
        position["orthometric_height_m"] = json!(g.h - n);
        position["height_model"] = json!(heights.short());
        position["geoid_undulation_m"] = json!(n);
    }
    Ok(())
}

/// Report lines of a static solution.
pub fn lines(s: &StaticSolution, refer: Reference) -> Vec<String> {
    let g = s.pos.to_geodetic();
    let enu = enu_cov(&s.pos, &s.cov);
    let sd = |i: usize| enu[(i, i)].max(0.0).sqrt() * 1000.0;
    let hours = (s.span.1 - s.span.0).to_seconds() / 3600.0;
    vec![
        format!(
            "static {}: X {:.4} Y {:.4} Z {:.4} m (lat {:.9} lon {:.9} h {:.4} m)",
            refer_name(refer),
            s.pos.0.x,
            s.pos.0.y,
            s.pos.0.z,
            g.lat.to_degrees(),
            g.lon.to_degrees(),
            g.h
        ),
        format!(
            "  σ E {:.1} N {:.1} U {:.1} mm; {} (ratio {:.1}); {} epochs over {:.2} h, {} of them fixed",
            sd(0),
            sd(1),
            sd(2),
            if s.quality == Quality::Fixed { "fixed" } else { "float" },
            s.ratio,
            s.epochs,
            hours,
            s.fixed_epochs
        ),
        format!(
            "  post-fit residuals: phase RMS {:.1} mm (max {:.1} mm, {}), code RMS {:.2} m (max {:.2} m, {})",
            s.residuals.0.rms() * 1000.0,
            s.residuals.0.max_abs * 1000.0,
            s.residuals.0.count,
            s.residuals.1.rms(),
            s.residuals.1.max_abs,
            s.residuals.1.count
        ),
    ]
}
