//! The converted MicMac camera and orientations reproduce MicMac's projection of the
//! Saisies-MMV1 block: 1.43 px RMS against the measurements, as the data's README states.

use super::*;
use photo::camera::Pose;

use testkit::shared_data as shared;

#[test]
fn saisies_projection_matches_micmac() {
    let Some(dir) = shared("photo/micmac-formats/Saisies-MMV1") else {
        return;
    };
    let ori = dir.join("Ori-Ground_mm3d");
    let cal = read_calibration(&ori.join("AutoCal_Foc-28000_Cam-PENTAX_K5.xml")).unwrap();
    let conv = cal.to_camera(5e-6).unwrap();
    let dico = read_dico(&dir.join("Ground-Pts3D.xml")).unwrap();
    let mes = read_mesures(&dir.join("GroundMeasure.xml")).unwrap();
    let flip = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
    let (mut ss, mut n, mut ss_mm) = (0.0, 0, 0.0);
    for (im, pt, c, r, _) in &mes {
        let Some((_, x, _)) = dico.iter().find(|d| d.0 == *pt) else {
            continue;
        };
        let (_, centre, rot) =
            read_orientation(&ori.join(format!("Orientation-{im}.xml"))).unwrap();
        let pose = Pose {
            r: rot * flip,
            centre,
        };
        let px = conv
            .camera
            .image_to_pixel(conv.camera.project(&pose, x).unwrap());
        let mm = cal.project(&(rot.transpose() * (x - centre))).unwrap();
        ss += (px - nalgebra::Vector2::new(*c, *r)).norm_squared();
        ss_mm += (mm - nalgebra::Vector2::new(*c, *r)).norm_squared();
        n += 1;
    }
    let (rms, rms_mm) = ((ss / n as f64).sqrt(), (ss_mm / n as f64).sqrt());
    // 16 point–image pairs; MicMac's own formula gives 1.43 px, the converted camera (r⁹ term
    // fitted, ≤ 0.1 px) the same to 0.02 px.
    assert_eq!(n, 16);
    assert!((rms_mm - 1.43).abs() < 0.005, "MicMac formula: {rms_mm} px");
    assert!(
        (rms - rms_mm).abs() < 0.02,
        "ppkat {rms} px vs MicMac {rms_mm} px"
    );
}

/// GNSS positions without σ: survey-grade assumed and said; `--gnss-kind nav` gives metres
/// and a block offset; an explicit σ wins over the kind.
#[test]
fn gnss_assumptions_are_stated() {
    let job = |kind, sigma| MicMacJob {
        ground: PathBuf::new(),
        measures: PathBuf::new(),
        calibration: None,
        check: None,
        crs: None,
        gnss: None,
        gnss_sigma: sigma,
        gnss_kind: kind,
        orientations: None,
        pixel_um: 1.0,
        sigma_px: 1.0,
    };
    let (s, k, note) = gnss_assumptions(&job(None, None));
    assert_eq!((s, k), ([0.05, 0.10], GnssKind::Survey));
    assert!(
        note.contains("assumed survey-grade") && note.contains("--gnss-kind nav"),
        "{note}"
    );
    let (s, k, note) = gnss_assumptions(&job(Some(GnssKind::Navigation), None));
    assert_eq!((s, k), ([3.0, 5.0], GnssKind::Navigation));
    assert!(
        note.contains("one offset per strip") && note.contains("by --gnss-kind"),
        "{note}"
    );
    let (s, _, note) = gnss_assumptions(&job(Some(GnssKind::Navigation), Some([1.0, 2.0])));
    assert_eq!(s, [1.0, 2.0]);
    assert!(note.contains("from --gnss-sigma"), "{note}");
}
