//! Projection equivalence: points projected with the source model's own formula and with the
//! converted ppkat camera agree (≤ 1e-3 px when exact; the fit error otherwise).

use super::*;
use crate::camera::Pose;
use nalgebra::Matrix3;

/// Camera-frame points (source frame, z forward) that fall inside a `w` × `h` image of focal
/// `f` pixels with principal point near the centre, at depths 5–50.
fn points(f: f64, w: f64, h: f64) -> Vec<Vector3<f64>> {
    let mut out = Vec::new();
    for i in 0..9 {
        for j in 0..7 {
            let z = 5.0 + 45.0 * ((i * 7 + j) % 5) as f64 / 4.0;
            let u = (i as f64 / 8.0 - 0.5) * 0.98 * w;
            let v = (j as f64 / 6.0 - 0.5) * 0.98 * h;
            out.push(Vector3::new(u / f * z, v / f * z, z));
        }
    }
    out
}

/// Largest pixel difference between `source` and the ppkat camera on the same points; the
/// ppkat pose is the source's identity rotation with y and z flipped.
fn worst(
    cam: &Camera,
    pts: &[Vector3<f64>],
    source: impl Fn(&Vector3<f64>) -> Vector2<f64>,
) -> f64 {
    let pose = Pose {
        r: Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0)),
        centre: Vector3::zeros(),
    };
    pts.iter()
        .map(|p| {
            let xy = cam.project(&pose, p).expect("in front");
            (cam.image_to_pixel(xy) - source(p)).norm()
        })
        .fold(0.0, f64::max)
}

fn micmac(radial: Vec<f64>, p: [f64; 2], b: [f64; 2]) -> MicMacCalibration {
    MicMacCalibration {
        pp: [2788.07, 1874.60],
        f: 5589.93,
        size: [5634, 3754],
        cdist: [2770.54, 1893.86],
        radial,
        p,
        b,
    }
}

#[test]
fn micmac_modrad_is_exact() {
    let m = micmac(vec![-2.7e-9, 9.5e-17, 7.7e-25], [0.0; 2], [0.0; 2]);
    let c = m.to_camera(4.0e-6).unwrap();
    let pts = points(m.f, 5634.0, 3754.0);
    let e = worst(&c.camera, &pts, |p| m.project(p).unwrap());
    assert!(e < 1e-6, "ModRad: {e} px");
    assert!(c.max_error_px < 1e-6);
    // The distortion centre is 17.5 px left of and 19.3 px below the principal point.
    assert!((c.camera.dc[0] / 4.0e-6 + 17.53).abs() < 1e-9);
    assert!((c.camera.dc[1] / 4.0e-6 + 19.26).abs() < 1e-9);
    // The distortion is real: tens of pixels in the corners.
    let ideal = Camera {
        k: [0.0; 3],
        ..c.camera
    };
    assert!(worst(&ideal, &pts, |p| m.project(p).unwrap()) > 10.0);
}

#[test]
fn micmac_phgrstd_is_exact() {
    let m = micmac(
        vec![-4.1e-9, 2.6e-16, -9.9e-25],
        [2.2e-8, 1.3e-8],
        [2.2e-4, -5.6e-7],
    );
    let c = m.to_camera(3.9e-6).unwrap();
    let pts = points(m.f, 5634.0, 3754.0);
    let e = worst(&c.camera, &pts, |p| m.project(p).unwrap());
    assert!(e < 1e-6, "ModPhgrStd: {e} px");
    // Without the decentring and affinity terms the difference is ≥ 0.5 px.
    let plain = Camera {
        p: [0.0; 2],
        b: [0.0; 2],
        ..c.camera
    };
    assert!(worst(&plain, &pts, |p| m.project(p).unwrap()) > 0.5);
}

#[test]
fn micmac_r9_term_is_fitted() {
    // As the Pentax K5 calibration of Saisies-MMV1: four coefficients (r³ … r⁹).
    let m = MicMacCalibration {
        pp: [856.87, 577.61],
        f: 2112.04,
        size: [1728, 1152],
        cdist: [856.87, 577.61],
        radial: vec![-2.13e-8, 1.72e-15, 5.5e-21, -2.42e-27],
        p: [0.0; 2],
        b: [0.0; 2],
    };
    let c = m.to_camera(1e-5).unwrap();
    let pts = points(m.f, 1728.0, 1152.0);
    let e = worst(&c.camera, &pts, |p| m.project(p).unwrap());
    // The r⁹ term alone reaches 3 px in the corners; the least-squares fit leaves 0.04 px
    // inside 98 % of the frame and 0.10 px in the very corners.
    assert!(e < 0.05 && c.max_error_px < 0.12, "{e} {}", c.max_error_px);
    assert!(e <= c.max_error_px + 1e-9);
}

fn colmap(model: &str, params: &[f64]) -> ColmapCamera {
    ColmapCamera {
        model: model.into(),
        width: 4000,
        height: 2250,
        params: params.to_vec(),
    }
}

#[test]
fn colmap_exact_models() {
    for cam in [
        colmap("SIMPLE_PINHOLE", &[2929.8, 2010.0, 1120.0]),
        colmap("PINHOLE", &[2929.8, 2929.8, 2010.0, 1120.0]),
        colmap("SIMPLE_RADIAL", &[2929.8, 2010.0, 1120.0, -0.05]),
        colmap("RADIAL", &[2929.8, 2010.0, 1120.0, 0.0156, 0.0443]),
        colmap(
            "OPENCV",
            &[
                2929.8, 2929.8, 2010.0, 1120.0, 0.0156, 0.0443, -0.0016, 0.0009,
            ],
        ),
    ] {
        let c = cam.to_camera(1.56e-6).unwrap();
        let e = worst(&c.camera, &points(2929.8, 4000.0, 2250.0), |p| {
            cam.project(p).unwrap()
        });
        assert!(e < 1e-6 && c.max_error_px < 1e-6, "{}: {e} px", cam.model);
    }
}

#[test]
fn colmap_aspect_and_rational_are_fitted() {
    // Brighton Beach's COLMAP 3.8 camera (fx ≠ fy by 6.6 px): ppkat's affinity b1 acts on the
    // ideal point, OpenCV's aspect on the distorted one (which reaches ~60 px in the corners):
    // the fitted camera is within 0.05 px of COLMAP's everywhere in the frame.
    let cv = colmap(
        "OPENCV",
        &[
            2929.82, 2923.20, 2000.0, 1125.0, 0.01563, 0.04433, -0.00159, 0.00095,
        ],
    );
    let c = cv.to_camera(1.56e-6).unwrap();
    let pts = points(2923.2, 4000.0, 2250.0);
    let e = worst(&c.camera, &pts, |p| cv.project(p).unwrap());
    assert!(e < 0.05 && c.max_error_px < 0.05, "OPENCV fx≠fy: {e} px");
    assert!(
        (c.camera.b[0] - (2929.82 / 2923.20 - 1.0)).abs() < 2e-4,
        "b1 {}",
        c.camera.b[0]
    );
    // PINHOLE with fx ≠ fy is exactly an affinity.
    let ph = colmap("PINHOLE", &[2929.82, 2923.20, 2000.0, 1125.0]);
    let c = ph.to_camera(1.56e-6).unwrap();
    assert!(worst(&c.camera, &pts, |p| ph.project(p).unwrap()) < 1e-6);
    // FULL_OPENCV with a rational term: fitted, error stated.
    let full = colmap(
        "FULL_OPENCV",
        &[
            2929.8, 2929.8, 2000.0, 1125.0, 0.0156, 0.0443, -0.0016, 0.0009, 0.01, 0.02, 0.0, 0.0,
        ],
    );
    let c = full.to_camera(1.56e-6).unwrap();
    let e = worst(&c.camera, &pts, |p| full.project(p).unwrap());
    assert!(
        e < 0.05 && e <= c.max_error_px + 1e-9,
        "FULL_OPENCV: {e} px"
    );
}

#[test]
fn bad_models_are_errors() {
    assert_eq!(
        colmap("FISHEYE", &[1.0]).to_camera(1e-6).unwrap_err(),
        ConvertError::UnknownModel("FISHEYE".into())
    );
    assert!(matches!(
        colmap("OPENCV", &[1.0, 2.0]).to_camera(1e-6),
        Err(ConvertError::ParameterCount {
            expected: 8,
            found: 2,
            ..
        })
    ));
    assert!(colmap("PINHOLE", &[0.0, 1.0, 2.0, 3.0])
        .to_camera(1e-6)
        .is_err());
    assert!(micmac(vec![f64::NAN], [0.0; 2], [0.0; 2])
        .to_camera(1e-6)
        .is_err());
}

#[test]
fn huge_principal_points_end_in_a_camera_not_an_endless_svd() {
    // fx ≠ fy asks for the distortion fit; cx = 1e300 overflowed r⁶ to inf and the column
    // scaling to NaN, on which nalgebra's SVD (no iteration bound) never returned.
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = done.clone();
    let worker = std::thread::spawn(move || {
        let r = colmap("PINHOLE", &[3000.0, 2900.0, 1e300, 1500.0]).to_camera(1e-6);
        flag.store(true, std::sync::atomic::Ordering::SeqCst);
        r.map(|c| c.camera.k)
    });
    let start = std::time::Instant::now();
    while !done.load(std::sync::atomic::Ordering::SeqCst) {
        assert!(start.elapsed().as_secs() < 30, "the conversion hangs");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    if let Ok(k) = worker.join().expect("no panic") {
        assert_eq!(k, [0.0; 3], "no fitted distortion from overflowed values");
    }
}
