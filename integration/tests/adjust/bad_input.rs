//! Bad projects give clear errors naming files, lines and ids; no output is written.

use super::*;

#[test]
fn bad_input_gives_clear_errors() {
    // A strip without GNSS: its antenna records are missing.
    let d = project_dir("bad-strip");
    edit(&d, "antennas.csv", |t| {
        t.lines()
            .filter(|l| !l.starts_with('2'))
            .collect::<Vec<_>>()
            .join("\n")
    });
    let e = fails(&d);
    assert!(e.contains("strip 2 (14 images) without any GNSS"), "{e}");
    // Control ids that are not in the measurements.
    let d = project_dir("bad-gcp");
    edit(&d, "ground_points.csv", |t| t.replacen("G2,", "G2x,", 1));
    let e = fails(&d);
    assert!(e.contains("G2x are not measured in any image"), "{e}");
    // A datum defect: no control, no GNSS.
    let d = project_dir("bad-datum");
    edit(&d, "project.toml", |t| {
        t[..t.find("[gnss]").unwrap()].to_string()
    });
    edit(&d, "ground_points.csv", |t| {
        t.lines()
            .filter(|l| !l.contains(",gcp,"))
            .collect::<Vec<_>>()
            .join("\n")
    });
    let e = fails(&d);
    assert!(
        e.contains("datum defect: 0 control point(s) and no GNSS"),
        "{e}"
    );
    // A measurement naming an unknown image: file and line.
    let d = project_dir("bad-meas");
    edit(&d, "image_observations.csv", |t| {
        format!("{t}777,T1,10,10,0.5\n")
    });
    let e = fails(&d);
    assert!(
        e.contains("image_observations.csv, line")
            && e.contains("image `777` is not in the image list"),
        "{e}"
    );
    // A point measured twice in one image: both lines named.
    let d = project_dir("bad-dup");
    edit(&d, "image_observations.csv", |t| {
        let second = t.lines().nth(1).unwrap().to_string();
        format!("{t}{second}\n")
    });
    let e = fails(&d);
    assert!(
        e.contains("is measured twice in image") && e.contains("(lines 2 and"),
        "{e}"
    );
    // Measurements made on images of another size than the calibration's.
    let d = project_dir("bad-size");
    edit(&d, "image_observations.csv", |t| {
        let mut l: Vec<String> = t.lines().map(String::from).collect();
        let f: Vec<&str> = l[3].split(',').collect();
        let x: f64 = f[2].parse().unwrap();
        l[3] = format!("{},{},{},{}", f[0], f[1], x + 1.0e5, f[3..].join(","));
        l.join("\n") + "\n"
    });
    let e = fails(&d);
    assert!(
        e.contains("image_observations.csv, line 4")
            && e.contains("is the calibration for another image size"),
        "{e}"
    );
    // A coordinate that is not a finite number.
    let d = project_dir("bad-nan");
    edit(&d, "ground_points.csv", |t| {
        let mut l: Vec<String> = t.lines().map(String::from).collect();
        let f: Vec<&str> = l[1].split(',').collect();
        l[1] = format!("{},{},NaN,{}", f[0], f[1], f[3..].join(","));
        l.join("\n")
    });
    let e = fails(&d);
    assert!(
        e.contains("ground_points.csv, line 2") && e.contains("`NaN` is not a number"),
        "{e}"
    );
    // An unknown key in the project file.
    let d = project_dir("bad-key");
    edit(&d, "project.toml", |t| {
        t.replace("drift_model", "drift_modle")
    });
    let e = fails(&d);
    assert!(e.contains("drift_modle"), "{e}");
    for n in [
        "bad-strip",
        "bad-gcp",
        "bad-datum",
        "bad-meas",
        "bad-key",
        "bad-dup",
        "bad-size",
    ] {
        let _ = std::fs::remove_dir_all(tmp(n));
    }
}

/// Images and points the observations do not determine are named with the reason and left
/// out; the rest is adjusted: an image without points, an image with one point (2 image
/// rows + 3 GNSS rows for six elements), and with it the points only it saw a second time.
#[test]
fn undetermined_images_are_named_and_left_out() {
    let d = project_dir("left-out");
    edit(&d, "images.csv", |t| {
        format!("{t}999,cam,1,2314,503700.0\n")
    });
    edit(&d, "image_observations.csv", |t| {
        let mut kept_103 = 0;
        t.lines()
            .filter(|l| {
                if !l.starts_with("103,") {
                    return true;
                }
                // Tie points only: check points never enter the adjustment.
                if !l.starts_with("103,T") {
                    return false;
                }
                kept_103 += 1;
                kept_103 == 1
            })
            .map(|l| format!("{l}\n"))
            .collect()
    });
    let r = adjust::run(&d.join("project.toml"), &d.join("out"), &Default::default())
        .expect("the rest adjusts");
    let said = |needle: &str| r.warnings.iter().any(|w| w.contains(needle));
    assert!(
        said("image 999 is left out of the adjustment: no measured points"),
        "{:?}",
        r.warnings
    );
    assert!(
        said("image 103 is left out of the adjustment: its observations give 5 equations"),
        "{:?}",
        r.warnings
    );
    assert_eq!(r.images.len(), 28, "29 simulated images, 103 and 999 out");
    assert!(r.images.iter().all(|i| i.id != "103" && i.id != "999"));
    assert!(r.sigma0 > 0.8 && r.sigma0 < 1.2, "σ0 {}", r.sigma0);
    assert!(r.checks.rms.iter().all(|&x| x < 0.3), "{:?}", r.checks.rms);
    let _ = std::fs::remove_dir_all(&d);
}

/// Data snooping never aborts: an image held by two points and its GNSS centre has a single
/// redundant component; a blunder there cannot be removed without leaving the image
/// undetermined, so it is kept (weighted down), flagged and reported, and the adjustment
/// finishes without removing the neighbours its blunder would otherwise spread into.
#[test]
fn snooping_keeps_what_it_cannot_remove() {
    let d = project_dir("snoop-keep");
    edit(&d, "image_observations.csv", |t| {
        let mut kept_103 = 0;
        t.lines()
            .filter_map(|l| {
                if !l.starts_with("103,") {
                    return Some(format!("{l}\n"));
                }
                // Two points seen by many images (T17 in six, T37 in four).
                if !(l.starts_with("103,T17,") || l.starts_with("103,T37,")) {
                    return None;
                }
                kept_103 += 1;
                match kept_103 {
                    // A 40 px blunder in x on the first point.
                    1 => {
                        let f: Vec<&str> = l.split(',').collect();
                        let x: f64 = f[2].parse().unwrap();
                        Some(format!(
                            "{},{},{:.3},{},{}\n",
                            f[0],
                            f[1],
                            x + 40.0,
                            f[3],
                            f[4]
                        ))
                    }
                    2 => Some(format!("{l}\n")),
                    _ => None,
                }
            })
            .collect()
    });
    let r = adjust::run(&d.join("project.toml"), &d.join("out"), &Default::default())
        .expect("snooping must not abort");
    assert!(r.images.iter().any(|i| i.id == "103"), "103 stays adjusted");
    eprintln!(
        "removed {:?}\nkept {:?}\nwarn {:?}",
        r.removed, r.kept_suspects, r.warnings
    );
    assert!(!r.kept_suspects.is_empty(), "the blunder is flagged");
    assert!(
        r.kept_suspects.iter().all(|k| k.what.contains("103")),
        "{:?}",
        r.kept_suspects
    );
    // Kept with next to no weight, the blunder does not spread: nothing innocent is removed.
    assert!(r.removed.is_empty(), "{:?}", r.removed);
    assert!(
        r.warnings
            .iter()
            .any(|w| w.contains("is kept: removing it would leave a parameter undetermined")),
        "{:?}",
        r.warnings
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// An image the antenna table does not name is adjusted from its points and counted in a
/// warning naming it, never silently.
#[test]
fn images_without_antenna_are_named() {
    let d = project_dir("no-antenna");
    edit(&d, "antennas.csv", |t| {
        t.lines()
            .filter(|l| !l.starts_with("105,"))
            .map(|l| format!("{l}\n"))
            .collect()
    });
    let r = adjust::run(&d.join("project.toml"), &d.join("out"), &Default::default()).unwrap();
    assert!(
        r.warnings
            .iter()
            .any(|w| w.starts_with("1 image(s) have no antenna record") && w.contains("105")),
        "{:?}",
        r.warnings
    );
    assert!(r.images.iter().any(|i| i.id == "105"));
    let _ = std::fs::remove_dir_all(&d);
}
