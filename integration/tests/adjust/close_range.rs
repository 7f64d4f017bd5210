//! Two terrestrial stations with compass angles, and three.

use super::*;

/// Close range: two stations 120 m apart, 380 m from the target, positions from GNSS,
/// compass angles 2° off refined by three-angle resection on 3 control points, then the
/// adjustment; check points reported as latitude/longitude/height differences.
#[test]
fn close_range_pair() {
    use integration::simulate::closerange::{close_range, CloseRangeSpec};
    let (mut e2, mut t2, mut n) = ([0.0; 3], [0.0; 3], 0.0);
    let mut worst_h: f64 = 0.0;
    for seed in 1..17u64 {
        let spec = CloseRangeSpec {
            seed,
            ..Default::default()
        };
        let dir = tmp(&format!("cr-{seed}"));
        close_range(&spec, &dir).unwrap();
        let r = adjust::run(
            &dir.join("project.toml"),
            &dir.join("out"),
            &Default::default(),
        )
        .unwrap();
        let c = &r.checks;
        assert_eq!(c.points.len(), 12);
        for a in 0..3 {
            e2[a] += c.rms[a].powi(2) * 12.0;
            t2[a] += c.theoretical_rms[a].powi(2) * 12.0;
        }
        n += 12.0;
        // The geodetic differences agree with the local ones (1″ of latitude ≈ 30.9 m).
        for q in &c.points {
            assert!(
                (q.dlat_arcsec * 30.87 - q.d[1]).abs() < 0.01 * q.d[1].abs().max(0.01) + 1e-3,
                "{q:?}"
            );
            assert!((q.dh - q.d[2]).abs() < 2e-3, "{q:?}");
            worst_h = worst_h.max(q.dh.abs());
        }
        if seed == 1 {
            let html = std::fs::read_to_string(dir.join("out/report.html")).unwrap();
            assert!(
                html.contains("Δlat ″") && html.contains("<svg"),
                "close-range report"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    let ratio: Vec<f64> = (0..3).map(|a| (e2[a] / t2[a]).sqrt()).collect();
    eprintln!(
        "close range: check RMS E/N/U {:.3} {:.3} {:.3} m, theoretical {:.3} {:.3} {:.3} m, worst |Δh| {worst_h:.3} m",
        (e2[0] / n).sqrt(), (e2[1] / n).sqrt(), (e2[2] / n).sqrt(), (t2[0] / n).sqrt(), (t2[1] / n).sqrt(), (t2[2] / n).sqrt()
    );
    for r in &ratio {
        assert!(*r < 1.25 && *r > 0.75, "check RMS / theoretical {ratio:?}");
    }
    // Three stations (−60, 0, +60 m): the middle one adds rays, the depth error shrinks.
    let spec = CloseRangeSpec {
        seed: 3,
        stations: vec![-60.0, 0.0, 60.0],
        ..Default::default()
    };
    let dir = tmp("cr-three");
    close_range(&spec, &dir).unwrap();
    let r = adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap();
    assert_eq!(r.images.len(), 3);
    assert!(r.checks.theoretical_rms[1] < (t2[1] / n).sqrt());
    for a in 0..3 {
        assert!(
            r.checks.rms[a] < 2.0 * r.checks.theoretical_rms[a],
            "{:?}",
            r.checks
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
