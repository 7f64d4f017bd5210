//! Attitude observations with a boresight: the classic block's antenna table given the true
//! camera attitude rotated by a known misalignment plus noise; the adjustment recovers the
//! misalignment within its σ.

use super::*;
use gnss::frame::{enu_rotation, Geodetic};
use nalgebra::{Matrix3, Vector3};
use photo::rotation::{exp_so3, Angles};

/// `omega,phi,kappa` columns (degrees) of a rotation camera → ENU.
fn opk_columns(r: &Matrix3<f64>) -> String {
    let Angles::OmegaPhiKappa { omega, phi, kappa } = Angles::omega_phi_kappa(r) else {
        unreachable!("omega_phi_kappa returns that convention")
    };
    format!(
        "{:.7},{:.7},{:.7}",
        omega.to_degrees(),
        phi.to_degrees(),
        kappa.to_degrees()
    )
}

/// The camera rotation of a truth pose (ENU at `origin`) in the ENU at `at`.
fn at_antenna(r: &Matrix3<f64>, origin: &Geodetic, at: &Geodetic) -> Matrix3<f64> {
    enu_rotation(at) * enu_rotation(origin).transpose() * r
}

/// The classic block adjusted with the antenna table's attitude: the true one times the
/// boresight (0.1, −0.2, 0.3)° plus 0.01° of noise per axis, its σ 0.01° from the table's
/// `sd_omega,sd_phi,sd_kappa` columns (`sd_columns`) or from `[attitude] sigma_deg`.
fn adjust_with_attitude(name: &str, sd_columns: bool) -> Results {
    let dir = tmp(name);
    let mut spec = BlockSpec::classic();
    spec.project_options = gnss_options("linear");
    let truth = block::aerial(&spec, &dir).unwrap();
    // R = R_obs · exp(b): the IMU gives R_obs = R · exp(b)ᵀ, with 0.01° of noise per axis.
    let b = Vector3::new(0.1f64, -0.2, 0.3).map(f64::to_radians);
    let noise = 0.01f64.to_radians();
    let k = std::cell::Cell::new(1u32);
    let next = || {
        // A fixed, deterministic sequence in [-1.7, 1.7] (uniform, σ ≈ 1).
        k.set(k.get().wrapping_mul(1_103_515_245).wrapping_add(12_345));
        ((k.get() >> 8) as f64 / (1u32 << 24) as f64 - 0.5) * 3.46
    };
    let sd = if sd_columns { ",0.01,0.01,0.01" } else { "" };
    edit(&dir, "antennas.csv", |t| {
        let mut out = String::new();
        for l in t.lines() {
            if l.starts_with('#') {
                out += l;
            } else if l.starts_with("id,") {
                out += &format!("{l},omega,phi,kappa");
                if sd_columns {
                    out += ",sd_omega,sd_phi,sd_kappa";
                }
            } else {
                let f: Vec<&str> = l.split(',').collect();
                let im = truth.images.iter().find(|i| i.0 == f[0]).unwrap();
                let (lat, lon): (f64, f64) = (f[3].parse().unwrap(), f[4].parse().unwrap());
                let at = Geodetic::from_degrees(lat, lon, 0.0);
                let e = Vector3::new(next(), next(), next()) * noise;
                let r_obs =
                    at_antenna(&im.2.r, &truth.origin, &at) * exp_so3(&b).transpose() * exp_so3(&e);
                out += &format!("{l},{}{sd}", opk_columns(&r_obs));
            }
            out += "\n";
        }
        out
    });
    let sigma = if sd_columns {
        ""
    } else {
        "sigma_deg = [0.01, 0.01, 0.01]\n"
    };
    edit(&dir, "project.toml", |t| {
        format!("{t}\n[attitude]\n{sigma}")
    });
    let r = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    r
}

#[test]
fn boresight_is_recovered_from_attitude_observations() {
    let r = adjust_with_attitude("attitude", false);
    let bs = &r.boresights[0];
    println!(
        "boresight {:?} ± {:?} (truth 0.1 -0.2 0.3 deg); σ0 {:.3}; groups {:?}",
        bs.values,
        bs.sigmas,
        r.sigma0,
        r.groups
            .iter()
            .map(|g| (&g.group, g.sigma_factor))
            .collect::<Vec<_>>()
    );
    for (a, t) in [0.1, -0.2, 0.3].iter().enumerate() {
        let e = bs.values[a] - t;
        assert!(
            e.abs() < 3.0 * bs.sigmas[a] + 1e-4,
            "axis {a}: {e} ± {}",
            bs.sigmas[a]
        );
        assert!(bs.sigmas[a] < 0.01, "σ {}", bs.sigmas[a]);
    }
    assert!(r
        .groups
        .iter()
        .any(|g| g.group == "attitude" && g.observations == 87));
    assert!((0.8..1.2).contains(&r.sigma0), "σ0 {}", r.sigma0);
}

/// The per-exposure σ of the antenna table (`sd_omega,sd_phi,sd_kappa`, no `sigma_deg`): the
/// same boresight within its σ, and with the same σ as `sigma_deg` gives the same result.
#[test]
fn antenna_table_attitude_sigma_is_used() {
    let r = adjust_with_attitude("attitude-sd", true);
    let bs = &r.boresights[0];
    for (a, t) in [0.1, -0.2, 0.3].iter().enumerate() {
        let e = bs.values[a] - t;
        assert!(e.abs() < 3.0 * bs.sigmas[a] + 1e-4, "axis {a}: {e}");
    }
    let reference = adjust_with_attitude("attitude-sd-ref", false);
    let rb = &reference.boresights[0];
    println!("σ {:?} vs {:?} from sigma_deg", bs.sigmas, rb.sigmas);
    for a in 0..3 {
        for (x, y) in [(bs.sigmas[a], rb.sigmas[a]), (bs.values[a], rb.values[a])] {
            assert!((x - y).abs() <= 1e-9 * y.abs(), "axis {a}: {x} vs {y}");
        }
    }
}

/// A camera mounted the other way round (image x against the flight): the start rotation from
/// the strip direction needs `[images] kappa_deg = 180`; with it the block adjusts as the
/// original one does.
#[test]
fn camera_mounting_sets_the_start_rotation() {
    let dir = tmp("mounting");
    let mut spec = BlockSpec::classic();
    spec.project_options = gnss_options("linear");
    block::aerial(&spec, &dir).unwrap();
    let original = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out0"),
        &Default::default(),
    )
    .unwrap();
    let size = |t: &str, key: &str| -> f64 {
        let l = t.lines().find(|l| l.starts_with(key)).unwrap();
        l.split('=').nth(1).unwrap().trim().parse().unwrap()
    };
    let project = std::fs::read_to_string(dir.join("project.toml")).unwrap();
    let (w, h) = (size(&project, "width_px"), size(&project, "height_px"));
    // The camera turned by 180° about its axis: every image point mirrored through the centre.
    edit(&dir, "image_observations.csv", |t| {
        t.lines()
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                match (f[2].parse::<f64>(), f[3].parse::<f64>()) {
                    (Ok(x), Ok(y)) => {
                        format!("{},{},{:.3},{:.3},{}\n", f[0], f[1], w - x, h - y, f[4])
                    }
                    _ => format!("{l}\n"),
                }
            })
            .collect()
    });
    // Without the mounting the start rotation is 180° off: the adjustment fails, or ends far
    // from the original.
    let wrong = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out2"),
        &Default::default(),
    );
    let far = match &wrong {
        Err(_) => true,
        Ok(r) => r.sigma0 > 2.0 || r.checks.rms.iter().any(|x| *x > 1.0),
    };
    assert!(far, "a start 180° off cannot give the original result");
    edit(&dir, "project.toml", |t| {
        t.replace("[images]\n", "[images]\nkappa_deg = 180\n")
    });
    let turned = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out1"),
        &Default::default(),
    )
    .unwrap();
    println!(
        "σ0 {:.3} vs {:.3}; checks {:?} vs {:?}",
        turned.sigma0, original.sigma0, turned.checks.rms, original.checks.rms
    );
    // The same block (the mirror is about the format centre, a half pixel from the principal
    // point's convention, so not to the bit).
    for a in 0..3 {
        assert!(
            (turned.checks.rms[a] - original.checks.rms[a]).abs() < 0.2 * original.checks.rms[a],
            "{:?} vs {:?}",
            turned.checks.rms,
            original.checks.rms
        );
    }
    assert!((turned.sigma0 - original.sigma0).abs() < 0.02);
    assert_eq!(turned.images.len(), original.images.len());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Navigation angles in the image list (`omega,phi,kappa`, camera → local ENU) are attitude
/// observations too: the same misalignment comes back (σ 0.05°: the list's frame is the
/// block origin's ENU, a few hundredths of a degree from the adjustment's).
#[test]
fn image_list_angles_are_observations() {
    let dir = tmp("attitude-list");
    let mut spec = BlockSpec::classic();
    spec.project_options = gnss_options("linear");
    let truth = block::aerial(&spec, &dir).unwrap();
    let b = Vector3::new(0.1f64, -0.2, 0.3).map(f64::to_radians);
    edit(&dir, "images.csv", |t| {
        let mut out = String::new();
        for l in t.lines() {
            if l.starts_with("image,") {
                out += &format!("{l},omega,phi,kappa\n");
                continue;
            }
            let id = l.split(',').next().unwrap();
            let im = truth.images.iter().find(|i| i.0 == id).unwrap();
            let r_obs = im.2.r * exp_so3(&b).transpose();
            out += &format!("{l},{}\n", opk_columns(&r_obs));
        }
        out
    });
    edit(&dir, "project.toml", |t| {
        format!("{t}\n[attitude]\nsigma_deg = [0.05, 0.05, 0.05]\n")
    });
    let r = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap();
    let bs = &r.boresights[0];
    println!("boresight from the list {:?} ± {:?}", bs.values, bs.sigmas);
    for (a, t) in [0.1, -0.2, 0.3].iter().enumerate() {
        assert!(
            (bs.values[a] - t).abs() < 0.05,
            "axis {a}: {}",
            bs.values[a]
        );
    }
    assert!(r
        .groups
        .iter()
        .any(|g| g.group == "attitude" && g.observations == 87));
    let _ = std::fs::remove_dir_all(&dir);
}
