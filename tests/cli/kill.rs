//! `kill -9` of `ppk` (over RINEX and over a real u-blox log), `convert`, `adjust`, `import`,
//! `match` and `exposures --geotag` at several moments, over the outputs of an earlier run: the earlier
//! outputs stay whole or the new ones appear whole, never a mix or a partial file, and the
//! next run leaves no temporary behind.

use super::*;
use std::time::Duration;

/// Start `args`, kill it (SIGKILL) after `after`, wait for it; whether the kill interrupted
/// it (its exit status is the signal) rather than finding it finished.
fn kill_after(args: &[&str], after: Duration) -> bool {
    use std::os::unix::process::ExitStatusExt;
    let mut child = Command::new(env!("CARGO_BIN_EXE_ppkat"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("start ppkat");
    std::thread::sleep(after);
    let _ = child.kill();
    let status = child.wait().expect("wait for ppkat");
    status.signal() == Some(9)
}

/// Run `args` to the end, asserting its exit code; how long it took.
fn timed_run(args: &[&str], code: i32) -> Duration {
    let t = std::time::Instant::now();
    let o = ppkat(args);
    assert_eq!(o.status.code(), Some(code), "{args:?}: {}", text(&o));
    t.elapsed()
}

/// The fastest of three reruns of `args` (exit code `code`). Under a loaded machine one
/// rerun can take twice as long as the next (geotag: 179 ms, then under 90), and kills
/// spread over the slow one landed after the fast ones had finished; a run slower than the
/// fastest is only the more surely interrupted.
fn fastest_rerun(args: &[&str], code: i32) -> Duration {
    (0..3)
        .map(|_| timed_run(args, code))
        .min()
        .expect("three runs")
}

/// The moments of the kills: spread over a run that took `run` (a tenth to nine tenths of
/// it, at least 5 ms), so that they land while it reads, computes and writes, not after it.
fn moments(run: Duration) -> [Duration; 5] {
    [0.1, 0.3, 0.5, 0.7, 0.9].map(|f| run.mul_f64(f).max(Duration::from_millis(5)))
}

/// Exit codes of the killed commands' whole runs: what each must end with, not "0 or 3".
const ADJUST_CODE: i32 = 0;
const IMPORT_CODE: i32 = 0;
const MATCH_CODE: i32 = 0;
const GEOTAG_CODE: i32 = 0;

/// Kills that must have interrupted a running process, of the five: the later ones may
/// find a run that went faster than the first finished.
const MIN_INTERRUPTED: usize = 3;

/// Assert that enough of the kills interrupted the run (`hits` per moment).
fn assert_interrupted(what: &str, run: Duration, hits: &[(Duration, bool)]) {
    let n = hits.iter().filter(|h| h.1).count();
    assert!(
        n >= MIN_INTERRUPTED && hits[0].1,
        "{what}: only {n} of {} kills interrupted a run of {run:?} ({hits:?}): the test would check finished runs",
        hits.len()
    );
}

/// The names in a folder.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// The files of a folder (and of its folders, as `sub/name`) with their contents.
fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
    names(dir)
        .into_iter()
        .flat_map(|n| {
            let p = dir.join(&n);
            if p.is_dir() {
                contents(&p)
                    .into_iter()
                    .map(|(m, b)| (format!("{n}/{m}"), b))
                    .collect()
            } else {
                vec![(n, std::fs::read(p).unwrap())]
            }
        })
        .collect()
}

/// Mark an earlier run's output as old: a comment line appended to the file.
fn mark_old(path: &Path) {
    let mut b = std::fs::read(path).unwrap();
    b.extend_from_slice(b"# old run\n");
    std::fs::write(path, b).unwrap();
}

#[test]
fn killed_ppk_leaves_the_earlier_pos_whole() {
    let demo = demo_dir();
    let dir = tmp("kill-ppk");
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("out.pos");
    let (rover, base, nav) = (
        demo.join("rover.obs"),
        demo.join("base.obs"),
        demo.join("nav.rnx"),
    );
    killed_ppk_runs(&ppk_args(&rover, &base, &[&nav], &out, &[]), &dir, &out);
}

/// The same over u-blox logs read directly: the simulated flight's rover and base as UBX
/// (`simulate --raw ubx`), 3.8 km apart, against the exact trajectory: every epoch fixed,
/// the worst 2.5 cm off (as from the RINEX). The real u-blox log's decoding is checked value
/// by value against RTKLIB's in `gnss/tests/ubx_convert.rs`; it has no second station to
/// make a baseline with.
#[test]
fn killed_ppk_of_ubx_logs_leaves_the_earlier_pos_whole() {
    let sim = tmp("kill-ppk-ubx-sim");
    let _ = std::fs::remove_dir_all(&sim);
    let t = succeeds(&ppkat(&[
        "simulate",
        "--builtin",
        "demo",
        "--raw",
        "ubx",
        "-o",
        p(&sim),
    ]));
    let base_flag = format!("--base-pos={}", simulated_base_xyz(&t));
    let dir = tmp("kill-ppk-ubx");
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("out.pos");
    let (rover, base, nav) = (
        sim.join("rover.ubx"),
        sim.join("base.ubx"),
        sim.join("nav.rnx"),
    );
    let args = ppk_args(
        &rover,
        &base,
        &[&nav],
        &out,
        &[&base_flag, "--format", "xyz"],
    );
    killed_ppk_runs(&args, &dir, &out);
    let rows = pos_rows(&out);
    assert_eq!(rows.len(), 2379, "every rover epoch solved");
    let (compared, fixed, worst) = against_sim_truth(&sim, &rows, 0.0);
    assert_eq!((compared, fixed), (2379, 2379), "every epoch fixed");
    assert!(
        worst < 0.04,
        "worst fixed epoch {worst:.4} m off (0.025 measured)"
    );
}

/// Run the `ppk` of `args` (writing `out`, alone in `dir`) once, mark its output as old, then
/// kill reruns at each of its [`moments`] (most must interrupt it): `out` is the old file or
/// the new one, never a partial one; a last run writes the first run's file bit for bit and
/// leaves no temporary.
fn killed_ppk_runs(args: &[&str], dir: &Path, out: &Path) {
    timed_run(args, 0);
    let run = fastest_rerun(args, 0);
    let new = std::fs::read(out).unwrap();
    mark_old(out);
    let old = std::fs::read(out).unwrap();
    let mut hits = Vec::new();
    for at in moments(run) {
        hits.push((at, kill_after(args, at)));
        let now = std::fs::read(out).unwrap();
        assert!(now == old || now == new, "killed at {at:?}: a partial .pos");
        // Only the output itself, and perhaps the killed run's hidden temporary.
        for n in names(dir) {
            assert!(n == "out.pos" || n.starts_with(".out.pos."), "{n}");
        }
        std::fs::write(out, &old).unwrap();
    }
    assert_interrupted("ppk", run, &hits);
    succeeds(&ppkat(args));
    assert_eq!(std::fs::read(out).unwrap(), new, "reruns are bit-identical");
    assert_eq!(
        names(dir),
        ["out.pos"],
        "the next run removed the temporaries"
    );
}

/// Run `args` (whose output is the folder `out`, alone in `work`; exit code `code`) twice,
/// timing the second, mark its files as old, then kill reruns at each of its [`moments`] (most must interrupt
/// it): `out` holds the old files or the new ones, never a mix; a last run writes the first
/// run's files bit for bit and leaves no temporary behind. Returns the first run's time.
fn killed_runs_leave_the_folder_whole(
    args: &[&str],
    work: &Path,
    out: &Path,
    min_files: usize,
    code: i32,
) -> Duration {
    let name = out.file_name().unwrap().to_string_lossy().into_owned();
    // The first run fills caches (match's features); the kills time the reruns.
    timed_run(args, code);
    let run = fastest_rerun(args, code);
    let new = contents(out);
    assert!(new.len() >= min_files, "{:?}", names(out));
    // Files only: a folder inside (match's feature cache) holds what both runs share.
    for n in names(out).into_iter().filter(|n| out.join(n).is_file()) {
        mark_old(&out.join(n));
    }
    let old = contents(out);
    let mut hits = Vec::new();
    for at in moments(run) {
        hits.push((at, kill_after(args, at)));
        let ms = at.as_millis();
        if !out.exists() {
            // Killed between the two renames of the swap: the old folder is beside it, whole,
            // and the next run puts it back.
            let parked: Vec<String> = names(work)
                .into_iter()
                .filter(|n| n.ends_with(".old"))
                .collect();
            assert_eq!(parked.len(), 1, "{:?}", names(work));
            assert_eq!(contents(&work.join(&parked[0])), old, "killed at {ms} ms");
            timed_run(args, code);
        }
        let now = contents(out);
        assert!(
            now == old || now == new,
            "killed at {ms} ms: a mix of old and new files: {:?}",
            now.iter()
                .map(|(n, b)| (n, old.iter().any(|o| &o.1 == b)))
                .collect::<Vec<_>>()
        );
        for n in names(work) {
            assert!(n == name || n.starts_with(&format!(".{name}.")), "{n}");
        }
        std::fs::remove_dir_all(out).unwrap();
        std::fs::create_dir_all(out).unwrap();
        for (n, b) in &old {
            let f = out.join(n);
            std::fs::create_dir_all(f.parent().unwrap()).unwrap();
            std::fs::write(f, b).unwrap();
        }
    }
    assert_interrupted(args[0], run, &hits);
    timed_run(args, code);
    assert_eq!(contents(out), new, "reruns are bit-identical");
    assert_eq!(names(work), [name], "the next run removed the temporaries");
    run
}

#[test]
fn killed_adjust_leaves_the_earlier_folder_whole() {
    let work = tmp("kill-adjust");
    std::fs::create_dir_all(&work).unwrap();
    let out = work.join("adj");
    let project = demo_dir().join("project.toml");
    let args = ["adjust", "--project", p(&project), "-o", p(&out)];
    killed_runs_leave_the_folder_whole(&args, &work, &out, 6, ADJUST_CODE);
}

#[test]
fn killed_import_leaves_the_earlier_folder_whole() {
    let Some(photos) = shared("photo/brighton-beach") else {
        return;
    };
    let work = tmp("kill-import");
    std::fs::create_dir_all(&work).unwrap();
    let out = work.join("project");
    let model = photos.join("colmap-3.8");
    let args = [
        "import",
        "colmap",
        p(&model),
        "--gnss-exif",
        p(&photos),
        "-o",
        p(&out),
    ];
    killed_runs_leave_the_folder_whole(&args, &work, &out, 5, IMPORT_CODE);
}

#[test]
fn killed_match_leaves_the_earlier_folder_whole() {
    let Some(photos) = shared("photo/brighton-beach") else {
        return;
    };
    let work = tmp("kill-match");
    let input = tmp("kill-match-photos");
    std::fs::create_dir_all(&work).unwrap();
    std::fs::create_dir_all(&input).unwrap();
    // Four overlapping photos, reduced while decoded: a run of a few seconds.
    for n in 18..22 {
        let name = format!("DJI_{n:04}.JPG");
        std::fs::copy(photos.join(&name), input.join(&name)).unwrap();
    }
    let out = work.join("tie");
    let args = [
        &["match", "--photos", p(&input)][..],
        &QUICK_MATCH,
        &["-o", p(&out)],
    ]
    .concat();
    killed_runs_leave_the_folder_whole(&args, &work, &out, 6, MATCH_CODE);
}

/// A DJI Timestamp.MRK of the 18 Brighton Beach photos (DJI_0018 … DJI_0035), 3 s apart inside
/// the demo's flight.
fn brighton_mrk(path: &Path) {
    let mut body = String::new();
    for k in 0..18 {
        body += &format!(
            "{}\t{}\t[2318]\t0,N\t0,E\t0,V\t47.29,Lat\t8.555,Lon\t600,Ellh\t0.01, 0.01, 0.02\t50,Q\n",
            18 + k,
            291700 + 3 * k
        );
    }
    std::fs::write(path, body).unwrap();
}

#[test]
fn killed_geotag_leaves_the_earlier_folder_whole() {
    let Some(photos) = shared("photo/brighton-beach") else {
        return;
    };
    let work = tmp("kill-geotag");
    std::fs::create_dir_all(&work).unwrap();
    let (mrk, csv, out) = (
        tmp("kill-geotag.MRK"),
        tmp("kill-geotag.csv"),
        work.join("tagged"),
    );
    brighton_mrk(&mrk);
    let traj = demo_dir().join("rover_ppk.pos");
    let args = [
        "exposures",
        "--trajectory",
        p(&traj),
        "--mrk",
        p(&mrk),
        "--photos",
        p(&photos),
        "--geotag",
        p(&out),
        "-o",
        p(&csv),
    ];
    let run = killed_runs_leave_the_folder_whole(&args, &work, &out, 18, GEOTAG_CODE);
    // The stations file and the folder: the folder is swapped in only after the file, so a
    // killed run never leaves new tagged photos beside an old stations file.
    let new_csv = std::fs::read(&csv).unwrap();
    let new_dir = contents(&out);
    for at in moments(run) {
        let ms = at.as_millis();
        mark_old(&csv);
        for n in names(&out) {
            mark_old(&out.join(n));
        }
        let old_dir = contents(&out);
        kill_after(&args, at);
        if !out.exists() {
            timed_run(&args, GEOTAG_CODE);
            continue;
        }
        let (csv_now, dir_now) = (std::fs::read(&csv).unwrap(), contents(&out));
        let csv_new = csv_now == new_csv;
        assert!(
            csv_new || csv_now.ends_with(b"# old run\n"),
            "killed at {ms} ms: a partial csv"
        );
        assert!(
            dir_now == new_dir || dir_now == old_dir,
            "killed at {ms} ms: a mixed folder"
        );
        assert!(
            csv_new || dir_now == old_dir,
            "killed at {ms} ms: new tagged photos beside the old stations file"
        );
        timed_run(&args, GEOTAG_CODE);
    }
    // A stations file that cannot be written: the run fails and the folder stays as it was.
    for n in names(&out) {
        mark_old(&out.join(n));
    }
    let old_dir = contents(&out);
    let mut bad = args;
    let nowhere = work.join("missing-folder").join("stations.csv");
    bad[bad.len() - 1] = p(&nowhere);
    fails_with(&ppkat(&bad), &["missing-folder"]);
    assert_eq!(
        contents(&out),
        old_dir,
        "tagged copies swapped in for a failed run"
    );
    assert_eq!(names(&work), ["tagged"], "the staged copies are removed");
}

#[test]
fn killed_convert_leaves_the_earlier_rinex_whole_and_no_spill() {
    let Some(log) = shared("gnss/ubx-navsol-2025/16dBatt_no_interference_coldstart.ubx") else {
        return;
    };
    let (dir, fresh) = (tmp("kill-convert"), tmp("kill-convert-fresh"));
    for d in [&dir, &fresh] {
        let _ = std::fs::remove_dir_all(d);
        std::fs::create_dir_all(d).unwrap();
    }
    let args = |d: &Path| {
        let (o, n) = (d.join("out.obs"), d.join("out.nav"));
        let v: Vec<String> = ["convert", "--in", p(&log), "-o", p(&o), "--nav", p(&n)]
            .iter()
            .map(|s| s.to_string())
            .collect();
        v
    };
    let run = |d: &Path| {
        let a = args(d);
        succeeds(&ppkat(&a.iter().map(String::as_str).collect::<Vec<_>>()));
    };
    run(&fresh);
    let new = contents(&fresh);
    run(&dir);
    mark_old(&dir.join("out.obs"));
    mark_old(&dir.join("out.nav"));
    let old = contents(&dir);
    assert_ne!(old, new);
    let a = args(&dir);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    for ms in [2, 8, 20, 40, 80] {
        kill_after(&a, Duration::from_millis(ms));
        // each output is the earlier run's or the new one, whole; the spill is never seen
        let now = contents(&dir);
        for name in ["out.nav", "out.obs"] {
            let get = |c: &[(String, Vec<u8>)]| c.iter().find(|f| f.0 == name).cloned();
            let f = get(&now).expect("output present");
            assert!(
                f == get(&old).unwrap() || f == get(&new).unwrap(),
                "{name} at {ms} ms"
            );
        }
        assert!(
            names(&dir).iter().all(|n| !n.contains(".spill")),
            "{:?}",
            names(&dir)
        );
    }
    run(&dir);
    assert_eq!(contents(&dir), new);
    assert_eq!(names(&dir), ["out.nav", "out.obs"]);
}
