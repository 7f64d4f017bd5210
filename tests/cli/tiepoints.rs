//! `ppkat match`: the 18 real DJI photos of Brighton Beach become one block whose project
//! adjusts to an image-point RMS within 1 px; bad photos cost one message each.

use super::*;

#[test]
fn brighton_beach_photos_match_into_one_block_that_adjusts() {
    let Some(dir) = shared("photo/brighton-beach") else {
        return;
    };
    let out = tmp("match-brighton");
    let t = succeeds(&ppkat(&["match", "--photos", p(&dir), "-o", p(&out)]));
    eprintln!("{t}");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("match.json")).unwrap()).unwrap();
    let images = j["images"].as_array().unwrap();
    assert_eq!(images.len(), 18);
    // All in one block, the conifer strip (DJI_0018–0023) included.
    assert!(images.iter().all(|i| i["component"] == 0), "{j}");
    assert!(
        images
            .iter()
            .all(|i| i["observations"].as_u64().unwrap() > 150),
        "{j}"
    );
    let ge3 = j["tracks_3plus"].as_u64().unwrap();
    // COLMAP 3.8 on the same photos: 7,157 of its 7,751 points in 3 or more images.
    eprintln!("tie points in ≥ 3 photos: ppkat {ge3}, COLMAP 7157");
    assert!(ge3 >= 2500, "{ge3} tracks in 3 or more photos");
    // Six photos of the strip flown back carry a gimbal yaw turned by 180°: the overlaps win.
    assert_eq!(t.matches("the gimbal yaw differs").count(), 6, "{t}");
    let adj = out.join("adjusted");
    succeeds(&ppkat(&[
        "adjust",
        "--project",
        p(&out.join("project.toml")),
        "-o",
        p(&adj),
    ]));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(adj.join("report.json")).unwrap()).unwrap();
    let s0 = r["sigma0"].as_f64().unwrap();
    let num = |c: &str| -> Vec<f64> {
        column(&adj.join("image_residuals.csv"), c)
            .iter()
            .map(|x| x.parse().unwrap())
            .collect()
    };
    let (vx, vy) = (num("vx_px"), num("vy_px"));
    let rms = (vx.iter().chain(&vy).map(|v| v * v).sum::<f64>() / vx.len() as f64).sqrt();
    eprintln!(
        "σ0 {s0:.3}, image-point RMS {rms:.3} px over {} points",
        vx.len()
    );
    assert!(rms <= 1.0, "image-point RMS {rms} px");
    assert!((0.7..1.3).contains(&s0), "σ0 {s0}");
}

#[test]
fn bad_photos_cost_one_message_each_and_the_rest_are_matched() {
    let Some(dir) = shared("photo/brighton-beach") else {
        return;
    };
    let photos = tmp("match-bad");
    std::fs::create_dir_all(&photos).unwrap();
    for n in ["DJI_0025.JPG", "DJI_0026.JPG", "DJI_0027.JPG"] {
        std::fs::copy(dir.join(n), photos.join(n)).unwrap();
    }
    // A JPEG cut after its header, a PNG named .jpg with no EXIF (no focal length), a note.
    let good = std::fs::read(dir.join("DJI_0025.JPG")).unwrap();
    std::fs::write(photos.join("cut.jpg"), &good[..40_000]).unwrap();
    let png = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/exif/renamed_png.jpg");
    std::fs::copy(png, photos.join("renamed_png.jpg")).unwrap();
    std::fs::write(photos.join("notes.txt"), "flight notes").unwrap();
    let out = tmp("match-bad-out");
    let o = ppkat(
        &[
            &["match", "--photos", p(&photos)][..],
            &QUICK_MATCH,
            &["-o", p(&out)],
        ]
        .concat(),
    );
    let t = text(&o);
    assert_eq!(o.status.code(), Some(3), "{t}");
    assert!(t.contains("cut.jpg:"), "{t}");
    assert!(t.contains("renamed_png.jpg:"), "{t}");
    assert!(t.contains("3 in the block"), "{t}");
    assert!(t.contains("1 other files ignored"), "{t}");
    // One photo is not a block: a failure that says why.
    let one = tmp("match-one");
    std::fs::create_dir_all(&one).unwrap();
    std::fs::copy(dir.join("DJI_0025.JPG"), one.join("DJI_0025.JPG")).unwrap();
    fails_with(
        &ppkat(&["match", "--photos", p(&one), "-o", p(&tmp("match-one-out"))]),
        &["1 usable photograph", "at least two"],
    );
}
