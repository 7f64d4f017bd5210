//! `--threads` changes the speed, never the results: ppk, adjust, match and bal on 1, 2 and 8
//! threads write the same bytes (bal: the same report but for its wall time).

use super::*;

/// The thread counts compared.
const THREADS: [&str; 3] = ["1", "2", "8"];

/// The files of folder `dir`, recursively, by their path inside it, with their bytes.
fn files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    files_under(dir)
        .into_iter()
        .map(|rel| {
            let bytes = std::fs::read(dir.join(&rel)).unwrap();
            (rel, bytes)
        })
        .collect()
}

/// Run `args(out)` on each of [`THREADS`], each into a folder of its own under `name`, and
/// assert that every run ends with exit code `code` and every folder holds the same files
/// with the same bytes.
fn same_bytes_on_any_threads(name: &str, code: i32, args: impl Fn(&Path) -> Vec<String>) {
    let mut first: Option<Vec<(PathBuf, Vec<u8>)>> = None;
    for n in THREADS {
        let dir = tmp(&format!("threads-{name}-{n}"));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let mut a = vec!["--threads".to_string(), n.to_string()];
        a.extend(args(&dir.join("out")));
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let o = ppkat(&a);
        assert_eq!(o.status.code(), Some(code), "{a:?}: {}", text(&o));
        let now = files(&dir);
        assert!(!now.is_empty(), "{a:?} wrote nothing");
        match &first {
            None => first = Some(now),
            Some(f) => {
                for ((p1, b1), (p2, b2)) in f.iter().zip(&now) {
                    assert_eq!(p1, p2, "{name}: other files on {n} threads");
                    assert!(
                        b1 == b2,
                        "{name}: {} differs between 1 and {n} threads",
                        p1.display()
                    );
                }
                assert_eq!(f.len(), now.len(), "{name}: other files on {n} threads");
            }
        }
    }
}

/// Owned arguments.
fn owned(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| s.to_string()).collect()
}

#[test]
fn ppk_writes_the_same_bytes_on_any_threads() {
    let d = demo_dir();
    let (rover, base, nav) = (d.join("rover.obs"), d.join("base.obs"), d.join("nav.rnx"));
    same_bytes_on_any_threads("ppk", 0, |out| {
        std::fs::create_dir_all(out).unwrap();
        owned(&ppk_args(
            &rover,
            &base,
            &[&nav],
            &out.join("rover.pos"),
            &[],
        ))
    });
}

#[test]
fn adjust_writes_the_same_bytes_on_any_threads() {
    let project = demo_dir().join("project.toml");
    same_bytes_on_any_threads("adjust", 0, |out| {
        owned(&["adjust", "--project", p(&project), "-o", p(out)])
    });
}

/// The reduced textured block (2 × 4 rendered photos of 400 × 300 px), made once.
fn textured() -> &'static Path {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        use integration::simulate::textured::{textured_block, TexturedSpec};
        let d = tmp("threads-textured");
        textured_block(&TexturedSpec::reduced(), &d).unwrap();
        d
    })
}

#[test]
fn match_writes_the_same_bytes_on_any_threads() {
    let t = textured();
    let (photos, pos, cam) = (
        t.join("photos"),
        t.join("antennas.csv"),
        t.join("camera.toml"),
    );
    same_bytes_on_any_threads("match", 0, |out| {
        owned(&[
            "match",
            "--photos",
            p(&photos),
            "--exposures",
            p(&pos),
            "--camera",
            p(&cam),
            "-o",
            p(out),
        ])
    });
}

#[test]
fn bal_reports_the_same_on_any_threads() {
    let file = match shared("photo/bal/bal-ladybug-problem-49-7776-pre-shrink-1800.txt") {
        Some(f) => f,
        None => {
            let f = tmp("threads.bal");
            std::fs::write(&f, super::bal::small_problem()).unwrap();
            f
        }
    };
    let reports: Vec<String> = THREADS
        .iter()
        .map(|n| {
            let t = succeeds(&ppkat(&["--threads", n, "bal", p(&file)]));
            t.lines()
                .filter(|l| !l.starts_with("wall time:"))
                .collect::<Vec<_>>()
                .join("\n")
        })
        .collect();
    assert_eq!(reports[0], reports[1], "1 and 2 threads");
    assert_eq!(reports[0], reports[2], "1 and 8 threads");
}
