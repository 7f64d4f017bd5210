//! `ppkat match`: the 18 real DJI photos of Brighton Beach become one block whose project
//! adjusts to an image-point RMS within 1 px; bad photos cost one message each.

use super::*;

/// The Brighton Beach photos matched once for this test binary (features read from and
/// written to the cache the other tests of these photos share), with what `match` printed;
/// `None` without the shared data.
fn brighton_matched() -> Option<&'static (PathBuf, String)> {
    static MATCHED: std::sync::OnceLock<Option<(PathBuf, String)>> = std::sync::OnceLock::new();
    MATCHED
        .get_or_init(|| {
            let dir = shared("photo/brighton-beach")?;
            let out = tmp("match-brighton");
            // Features shared with the other tests of these photos (the same bytes as
            // extracted).
            let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("feature-cache");
            let t = succeeds(&ppkat(&[
                "match",
                "--photos",
                p(&dir),
                "--feature-cache",
                p(&cache),
                "-o",
                p(&out),
            ]));
            Some((out, t))
        })
        .as_ref()
}

/// The matched block adjusted once with its EXIF positions (`brighton_matched`): its folder.
fn brighton_adjusted() -> Option<&'static PathBuf> {
    static ADJUSTED: std::sync::OnceLock<Option<PathBuf>> = std::sync::OnceLock::new();
    ADJUSTED
        .get_or_init(|| {
            let (out, _) = brighton_matched()?;
            let adj = tmp("match-brighton-adjusted");
            succeeds(&ppkat(&[
                "adjust",
                "--project",
                p(&out.join("project.toml")),
                "-o",
                p(&adj),
            ]));
            Some(adj)
        })
        .as_ref()
}

#[test]
fn brighton_beach_photos_match_into_one_block() {
    let Some((out, t)) = brighton_matched() else {
        return;
    };
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
    // 2,797 before guided matching; 4,853 with it (16,000 features, 6,000 matched all with
    // all); 5,362 when tracks are completed at keypoints in further photos; 7,216 when they
    // are also measured by their patches where no keypoint is told apart.
    assert!(
        ge3 >= 7157,
        "{ge3} tracks in 3 or more photos (COLMAP 7,157)"
    );
    let completed = j["measurements_by_completion"].as_u64().unwrap();
    assert!(completed >= 800, "{completed} measurements by completion");
    let patches = j["measurements_by_patches"].as_u64().unwrap();
    assert!(patches >= 7000, "{patches} measurements by patches");
    let refined = j["measurements_refined"].as_u64().unwrap();
    assert!(refined >= 20000, "{refined} measurements refined");
    // Six photos of the strip flown back carry a gimbal yaw turned by 180°: the overlaps win.
    assert_eq!(t.matches("the gimbal yaw differs").count(), 6, "{t}");
}

/// A rerun on the same folder reads every photo's features and every pair's matches from the
/// cache beside the project and writes the same bytes (into a copy of the matched folder, so
/// that the tests reading the first run's outputs are not disturbed).
#[test]
fn brighton_beach_rematched_from_the_cache_writes_the_same_bytes() {
    let (Some(dir), Some((first, _))) = (shared("photo/brighton-beach"), brighton_matched()) else {
        return;
    };
    let out = tmp("match-brighton-again");
    let _ = std::fs::remove_dir_all(&out);
    for f in files_under(first) {
        let to = out.join(&f);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(first.join(&f), &to).unwrap();
    }
    let before: Vec<Vec<u8>> = ["image_observations.csv", "match.json", "project.toml"]
        .iter()
        .map(|f| std::fs::read(out.join(f)).unwrap())
        .collect();
    let again = succeeds(&ppkat(&["match", "--photos", p(&dir), "-o", p(&out)]));
    assert!(
        again.contains("features: 18 of 18 photos from the cache, 0 extracted"),
        "{again}"
    );
    assert!(
        again.contains("pair matches: 153 of 153 pairs from the cache, 0 matched"),
        "{again}"
    );
    for (f, b) in ["image_observations.csv", "match.json", "project.toml"]
        .iter()
        .zip(&before)
    {
        assert!(
            std::fs::read(out.join(f)).unwrap() == *b,
            "{f} differs after a rerun"
        );
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn brighton_beach_block_adjusts_within_a_pixel() {
    let Some(adj) = brighton_adjusted() else {
        return;
    };
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
    // COLMAP's measure: the mean length of the reprojection errors (0.70–0.80 px on these
    // photos).
    let mean = vx.iter().zip(&vy).map(|(x, y)| x.hypot(*y)).sum::<f64>() / vx.len() as f64;
    eprintln!(
        "σ0 {s0:.3}, image points: RMS {rms:.3} px, mean reprojection error {mean:.3} px over {} points",
        vx.len()
    );
    // 0.738 and 0.538 px with the sub-pixel measurements (0.748 and 0.594 with keypoints).
    assert!(rms <= 0.8, "image-point RMS {rms} px");
    assert!(mean <= 0.6, "mean reprojection error {mean} px");
    assert!((0.7..1.3).contains(&s0), "σ0 {s0}");
}

/// The matched project's `project.toml` without its `[gnss]` section and start file, and the
/// section (issue 48's runs without positions, or with them given back).
fn without_positions(matched: &Path) -> (String, String) {
    let toml = std::fs::read_to_string(matched.join("project.toml")).unwrap();
    let gnss_at = toml.find("\n[gnss]").unwrap();
    let base = toml[..gnss_at].replace("start = \"start.csv\"\n", "");
    (base, toml[gnss_at..].to_string())
}

/// Copy `files` of the matched folder into `dir` (made).
fn copy_matched(matched: &Path, dir: &Path, files: &[&str]) {
    std::fs::create_dir_all(dir).unwrap();
    for f in files {
        std::fs::copy(matched.join(f), dir.join(f)).unwrap();
    }
}

/// The matched block without its positions (issue 48): as a free network started from its
/// tie points alone (no positions, no control) it adjusts within 1 px.
#[test]
fn brighton_beach_block_adjusts_as_a_free_network_from_its_ties() {
    let Some((matched, _)) = brighton_matched() else {
        return;
    };
    let (base, _) = without_positions(matched);
    let free = tmp("match-brighton-free");
    let _ = std::fs::remove_dir_all(&free);
    copy_matched(matched, &free, &["images.csv", "image_observations.csv"]);
    std::fs::write(
        free.join("project.toml"),
        format!("{base}\n[datum]\nfree = true\n"),
    )
    .unwrap();
    let t = succeeds(&ppkat(&[
        "adjust",
        "--project",
        p(&free.join("project.toml")),
        "-o",
        p(&free.join("out")),
    ]));
    assert!(
        t.contains("18 images") && t.contains("a free network"),
        "{t}"
    );
    let rms: Vec<f64> = column(&free.join("out/orientations.csv"), "rms_px")
        .iter()
        .map(|x| x.parse().unwrap())
        .collect();
    assert!(rms.len() == 18 && rms.iter().all(|r| *r <= 1.0), "{rms:?}");
}

/// With the EXIF positions given back to the block started from its ties (each image its
/// own strip, so no image starts from GNSS and a strip direction) it reaches the
/// GNSS-started result within its σ.
#[test]
fn brighton_beach_block_started_from_its_ties_reaches_the_gnss_started_result() {
    let (Some((matched, _)), Some(gnss_run)) = (brighton_matched(), brighton_adjusted()) else {
        return;
    };
    let (base, gnss) = without_positions(matched);
    let tied = tmp("match-brighton-tied");
    let _ = std::fs::remove_dir_all(&tied);
    copy_matched(matched, &tied, &["image_observations.csv", "antennas.csv"]);
    let images: Vec<String> = column(&matched.join("images.csv"), "image");
    let cams = column(&matched.join("images.csv"), "camera");
    let mut list = String::from("image,camera,strip\n");
    for (k, (i, c)) in images.iter().zip(&cams).enumerate() {
        list.push_str(&format!("{i},{c},{k}\n"));
    }
    std::fs::write(tied.join("images.csv"), list).unwrap();
    std::fs::write(tied.join("project.toml"), format!("{base}{gnss}")).unwrap();
    let t = succeeds(&ppkat(&[
        "adjust",
        "--project",
        p(&tied.join("project.toml")),
        "-o",
        p(&tied.join("out")),
    ]));
    assert!(
        t.contains("grown to 18 images by resection with local bundle adjustments, placed on 18 GNSS centres"),
        "{t}"
    );
    let centres = |dir: &Path| -> Vec<[f64; 6]> {
        let c = |n: &str| -> Vec<f64> {
            column(&dir.join("orientations.csv"), n)
                .iter()
                .map(|x| x.parse().unwrap())
                .collect()
        };
        let (e, n, h) = (c("e_local"), c("n_local"), c("u_local"));
        let (se, sn, su) = (c("sigma_e"), c("sigma_n"), c("sigma_u"));
        (0..e.len())
            .map(|i| [e[i], n[i], h[i], se[i], sn[i], su[i]])
            .collect()
    };
    let (a, b) = (centres(gnss_run), centres(&tied.join("out")));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        for k in 0..3 {
            assert!((x[k] - y[k]).abs() < x[3 + k], "{x:?} vs {y:?}");
        }
    }
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

/// `ppkat bench match` on a small rendered block: every stage timed, the tracks checked
/// against the truth; a second run reuses the rendered photos.
#[test]
fn bench_match_times_the_stages_and_checks_the_tracks() {
    let out = tmp("bench-match");
    let t = succeeds(&ppkat(&["bench", "match", "--photos", "8", "-o", p(&out)]));
    eprintln!("{t}");
    assert!(t.contains("block: 8 photos (1 strips × 8)"), "{t}");
    for stage in ["features", "matching", "project", "match in all"] {
        assert!(t.contains(&format!("stage {stage}: ")), "no {stage} in {t}");
    }
    assert!(t.contains("photos in the block: 8 of 8"), "{t}");
    let line = t.lines().find(|l| l.starts_with("tracks: ")).unwrap();
    let pct = number_after(line, "), ");
    assert!(pct >= 99.0, "{line}");
    let again = succeeds(&ppkat(&["bench", "match", "--photos", "8", "-o", p(&out)]));
    assert!(again.contains("rendered earlier (reused)"), "{again}");
    let _ = std::fs::remove_dir_all(&out);
}
