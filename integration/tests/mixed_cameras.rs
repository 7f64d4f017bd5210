//! Photos of two cameras in one folder (issue 50): grouped by model, image size and focal
//! length, each its own camera in the project, each self-calibrated. The Brighton Beach
//! photos are all of one Phantom 3; every other copy is retagged as another model whose
//! focal length only the 35 mm equivalent gives (7 % off the first's start). Both cameras
//! then come out at one focal length: each other's within 3 %, and COLMAP's (2,930 / 2,923
//! px on these photos) within 5 % (2,812 and 2,870 px today).

use integration::adjust::{run, RunOptions};
use integration::tiepoints::{self, project, MatchJob};
use testkit::{scratch_path as tmp, shared_data};

/// (value, σ) of the interior parameter `label` of the camera whose name holds `camera`, from
/// an adjustment's parameters.csv.
fn interior(out: &std::path::Path, camera: &str, label: &str) -> (f64, f64) {
    let text = std::fs::read_to_string(out.join("parameters.csv")).unwrap();
    let line = text
        .lines()
        .find(|l| {
            l.starts_with("interior,") && l.contains(camera) && l.contains(&format!(",{label},"))
        })
        .unwrap_or_else(|| panic!("no {label} of {camera} in\n{text}"));
    let f: Vec<&str> = line.rsplit(',').collect();
    // …,value,sigma,unit,fixed,t0 read from the end.
    (f[4].parse().unwrap(), f[3].parse().unwrap())
}

#[test]
fn two_cameras_in_one_folder_are_two_cameras_that_calibrate_alike() {
    let Some(src) = shared_data("photo/brighton-beach") else {
        return;
    };
    // The allocator as the ppkat binary sets it (large buffers reused, not mapped each time).
    common::memory::keep_large_buffers();
    let dir = tmp("mixed-cameras");
    let photos = dir.join("photos");
    std::fs::create_dir_all(&photos).unwrap();
    let mut names: Vec<_> = std::fs::read_dir(&src)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "JPG"))
        .collect();
    names.sort();
    assert_eq!(names.len(), 18);
    for (k, n) in names.iter().enumerate() {
        let to = photos.join(n.file_name().unwrap());
        std::fs::copy(n, &to).unwrap();
        if k % 2 == 1 {
            let mut m = little_exif::metadata::Metadata::new_from_path(&to).unwrap();
            m.set_tag(little_exif::exif_tag::ExifTag::Model("Survey X1".into()));
            m.write_to_file(&to).unwrap();
        }
    }
    // At the default size: matched at a quarter size (1000 px) the sub-pixel measurements'
    // weights pull the focal lengths 3–4 % longer (3,005 and 3,037 px; 2,877 and 2,900 with
    // every measurement at one σ) — noted, not yet understood.
    let mut job = MatchJob::new(photos);
    // Features shared with the other tests of these photos (the same bytes as extracted).
    job.shared_cache =
        Some(std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("feature-cache"));

    let m = tiepoints::run(&job, &|_, _, _| {}).unwrap();
    let w = project::build(&job, &m).unwrap();
    let cams: Vec<(&str, usize)> = w
        .cameras
        .iter()
        .map(|(id, _, n)| (id.as_str(), *n))
        .collect();
    eprintln!("cameras: {:?}", w.cameras);
    assert_eq!(cams.len(), 2, "{cams:?}");
    assert!(cams.iter().all(|(_, n)| *n == 9), "{cams:?}");
    let ids: Vec<&str> = cams.iter().map(|c| c.0).collect();
    assert!(ids.iter().any(|i| i.starts_with("DJI_FC300S_4000x2250_")));
    assert!(ids
        .iter()
        .any(|i| i.starts_with("DJI_Survey_X1_4000x2250_")));
    let proj = dir.join("project");
    w.project.write(&proj).unwrap();
    let images = std::fs::read_to_string(proj.join("images.csv")).unwrap();
    for (k, n) in names.iter().enumerate() {
        let id = n.file_stem().unwrap().to_string_lossy();
        let line = images
            .lines()
            .find(|l| l.starts_with(&format!("{id},")))
            .unwrap();
        assert_eq!(line.contains("Survey_X1"), k % 2 == 1, "{line}");
    }
    let out = dir.join("out");
    let r = run(&proj.join("project.toml"), &out, &RunOptions::default()).unwrap();
    assert_eq!(r.images.len(), 18);
    // Focal lengths in pixels: each camera's pixel size is its focal length in mm over its
    // start focal length in pixels (the id ends with it).
    let f_px = |id: &str| {
        let start: f64 = id.rsplit('_').next().unwrap().parse().unwrap();
        let (f, s) = interior(&out, id, "f");
        let pixel = 3.61e-3 / start;
        (f / pixel, s / pixel)
    };
    let (fa, sa) = f_px(ids[0]);
    let (fb, sb) = f_px(ids[1]);
    eprintln!(
        "f: {} {fa:.1} ± {sa:.1} px, {} {fb:.1} ± {sb:.1} px",
        ids[0], ids[1]
    );
    // The focal length is weakly determined by this block (EXIF GPS heights, flat ground):
    // the same photos give 2,812 to 2,976 px across settings (one camera, two, sub-pixel
    // measurements or not) while its formal σ is 12–16 px, so the cameras are held to agree
    // within 3 % and to lie within 5 % of COLMAP's, not to their σ.
    let colmap = (2929.8 + 2923.2) / 2.0;
    for f in [fa, fb] {
        assert!(
            (f / colmap - 1.0).abs() < 0.05,
            "f {f} px vs COLMAP {colmap}"
        );
    }
    assert!((fa / fb - 1.0).abs() < 0.03, "{fa} ± {sa} vs {fb} ± {sb}");
    let _ = std::fs::remove_dir_all(&dir);
}
