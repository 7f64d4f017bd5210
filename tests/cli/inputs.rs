//! Inputs are never modified: every command that reads files (spp, ppk, exposures with
//! geotagging, adjust, import, match, bal, convert) runs on inputs copied into a folder of
//! their own, whose every file has the same bytes and modification time afterwards.

use super::*;
use std::collections::BTreeMap;
use std::time::SystemTime;

/// Every file under `dir`, recursively, with its bytes and modification time.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, (Vec<u8>, SystemTime)> {
    let mut out = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let path = e.unwrap().path();
            let meta = std::fs::metadata(&path).unwrap();
            if meta.is_dir() {
                todo.push(path);
            } else {
                let bytes = std::fs::read(&path).unwrap();
                out.insert(path, (bytes, meta.modified().unwrap()));
            }
        }
    }
    out
}

/// Copy the files (not the folders) of `from` into `to`.
fn copy_files(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let path = e.unwrap().path();
        if path.is_file() {
            std::fs::copy(&path, to.join(path.file_name().unwrap())).unwrap();
        }
    }
}

/// The inputs: the demo flight and project, the reduced textured block (photos, camera,
/// positions), a photo and its exposure time, a PATB file, a BAL problem, and the real
/// u-blox log when the shared data is there.
fn inputs(dir: &Path) -> Option<PathBuf> {
    use integration::simulate::textured::{textured_block, TexturedSpec};
    copy_files(demo_dir(), &dir.join("demo"));
    textured_block(&TexturedSpec::reduced(), &dir.join("textured")).unwrap();
    std::fs::create_dir_all(dir.join("photos")).unwrap();
    std::fs::copy(fixture("photo_16x16.jpg"), dir.join("photos/a.jpg")).unwrap();
    std::fs::write(dir.join("times.csv"), "id,week,tow\nA,2318,291700\n").unwrap();
    std::fs::write(dir.join("patb.im"), "1\nT1 0.1 0.2\nT2 0.3 0.4\n-99\n").unwrap();
    std::fs::write(dir.join("small.bal"), super::bal::small_problem()).unwrap();
    let log = shared("gnss/ubx-navsol-2025/F9T-L2-5min.ubx")?;
    std::fs::copy(log, dir.join("f9t.ubx")).unwrap();
    Some(dir.join("f9t.ubx"))
}

#[test]
fn no_command_modifies_its_inputs() {
    let (inp, out) = (tmp("inputs-in"), tmp("inputs-out"));
    let ubx = inputs(&inp);
    std::fs::create_dir_all(&out).unwrap();
    let before = snapshot(&inp);
    let (d, t) = (inp.join("demo"), inp.join("textured"));
    let (rover, base, nav) = (d.join("rover.obs"), d.join("base.obs"), d.join("nav.rnx"));
    let o = |n: &str| out.join(n);
    let runs: Vec<Vec<String>> = [
        vec![
            "spp",
            "--obs",
            p(&rover),
            "--nav",
            p(&nav),
            "-o",
            p(&o("spp.pos")),
        ],
        ppk_args(&rover, &base, &[&nav], &o("ppk.pos"), &[]),
        vec![
            "exposures",
            "--trajectory",
            p(&d.join("rover_ppk.pos")),
            "--events",
            p(&rover),
        ]
        .into_iter()
        .chain(["-o", p(&o("events.csv"))])
        .collect(),
        vec!["exposures", "--trajectory", p(&d.join("rover_ppk.pos"))]
            .into_iter()
            .chain(["--times", p(&inp.join("times.csv"))])
            .chain([
                "--photos",
                p(&inp.join("photos")),
                "--geotag",
                p(&o("tagged")),
            ])
            .chain(["-o", p(&o("times.csv"))])
            .collect(),
        vec![
            "adjust",
            "--project",
            p(&d.join("project.toml")),
            "-o",
            p(&o("adj")),
        ],
        vec![
            "import",
            "patb",
            "--images",
            p(&inp.join("patb.im")),
            "--focal-mm",
            "35",
        ]
        .into_iter()
        .chain([
            "--pixel-um",
            "10",
            "--width-px",
            "1000",
            "--height-px",
            "800",
        ])
        .chain(["-o", p(&o("imp"))])
        .collect(),
        vec!["match", "--photos", p(&t.join("photos"))]
            .into_iter()
            .chain(["--exposures", p(&t.join("antennas.csv"))])
            .chain(["--camera", p(&t.join("camera.toml")), "-o", p(&o("match"))])
            .collect(),
        vec!["bal", p(&inp.join("small.bal"))],
    ]
    .into_iter()
    .map(|a| a.into_iter().map(String::from).collect())
    .collect();
    for args in &runs {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let r = ppkat(&args);
        assert!(
            matches!(r.status.code(), Some(0 | 3)),
            "{args:?}: {}",
            text(&r)
        );
    }
    if let Some(ubx) = &ubx {
        succeeds(&ppkat(&[
            "convert",
            "--in",
            p(ubx),
            "-o",
            p(&o("f9t.obs")),
            "--events",
            p(&o("f9t.csv")),
        ]));
    }
    let after = snapshot(&inp);
    assert_eq!(
        before.keys().collect::<Vec<_>>(),
        after.keys().collect::<Vec<_>>(),
        "no input file added or removed"
    );
    for (path, (bytes, time)) in &before {
        let (b, t) = &after[path];
        assert!(b == bytes, "{} modified", path.display());
        assert_eq!(t, time, "{} touched", path.display());
    }
    assert!(o("tagged/a.jpg").exists() && o("match/project.toml").exists());
}
