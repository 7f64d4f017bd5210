//! `ppkat batch --slurm --submit` on a real Slurm: a one-node cluster started on this machine
//! by `tests/slurm/cluster.sh` (Debian's slurm-wlm and munge, installed when missing), a plan
//! of simulated flights run as a job array with its merge after it, one flight that cannot
//! run, one task cancelled mid-run and submitted again — and every output the same, byte for
//! byte, as the same flights run here by `ppkat batch`.

use super::*;
use std::time::{Duration, Instant};

/// The test cluster: started by [`Cluster::up`], stopped when dropped.
struct Cluster {
    dir: PathBuf,
    conf: String,
}

/// The cluster script.
fn script() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/slurm/cluster.sh")
}

impl Cluster {
    /// Start it; None (the test skipped, said) only where PPKAT_SKIP_SLURM is set and this
    /// is not CI. Otherwise a cluster that cannot start fails the test with what to do.
    fn up() -> Option<Cluster> {
        let dir = std::env::temp_dir().join(format!("ppkat-slurm-{}", std::process::id()));
        let o = Command::new(script())
            .arg("up")
            .arg(&dir)
            .output()
            .expect("run tests/slurm/cluster.sh");
        let out = String::from_utf8_lossy(&o.stdout);
        if o.status.success() {
            let conf = out
                .lines()
                .find_map(|l| l.strip_prefix("SLURM_CONF="))
                .expect("cluster.sh names its slurm.conf")
                .to_string();
            return Some(Cluster { dir, conf });
        }
        let why = String::from_utf8_lossy(&o.stderr);
        let ci = std::env::var("CI").is_ok_and(|v| v == "true");
        if std::env::var_os("PPKAT_SKIP_SLURM").is_some() && !ci {
            eprintln!("skipped: the Slurm test cluster cannot start here: {why}");
            return None;
        }
        panic!(
            "the Slurm test cluster cannot start: {why}(where it cannot run, set PPKAT_SKIP_SLURM=1 to skip this test; on CI it must run)"
        );
    }

    /// `program` with this cluster's configuration.
    fn command(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", &self.conf);
        c
    }

    /// The end of the controller's log, for a failure's message.
    fn log(&self) -> String {
        let t = std::fs::read_to_string(self.dir.join("log/slurmctld.log")).unwrap_or_default();
        let lines: Vec<&str> = t.lines().collect();
        lines[lines.len().saturating_sub(15)..].join("\n")
    }

    /// Wait (at most `limit`) until `done` holds, else fail naming `what`.
    fn wait(&self, what: &str, limit: Duration, mut done: impl FnMut() -> bool) {
        let t0 = Instant::now();
        while !done() {
            assert!(
                t0.elapsed() < limit,
                "waited {limit:?} for {what}; the controller's log ends:\n{}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new(script()).arg("down").arg(&self.dir).output();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Every file under `dir` (relative paths, sorted), but the scheduler's own folders.
fn files(dir: &Path) -> Vec<PathBuf> {
    files_under(dir)
        .into_iter()
        .filter(|rel| {
            !["status", "logs", "slurm"]
                .iter()
                .any(|s| rel.starts_with(s))
        })
        .collect()
}

/// A flight's result without its report (which holds the run's duration).
fn result_fields(path: &Path) -> serde_json::Value {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v.as_object_mut().unwrap().remove("report");
    v
}

/// The folder of flights: four small simulated flights, one long one (`slow`, 17,292 epochs
/// at 20 Hz: seconds to run, time to cancel it) and one without a base (`broken`).
fn flights(root: &Path) -> PathBuf {
    let input = root.join("in");
    let small = std::fs::read_to_string(fixture("scenario_small.toml")).unwrap();
    let long = small
        .replace("strips = 1", "strips = 4")
        .replace("strip_length = 1000.0", "strip_length = 10000.0")
        .replace("rate_hz = 10.0", "rate_hz = 20.0");
    let long_path = root.join("long.toml");
    std::fs::write(&long_path, long).unwrap();
    let mut made = vec![];
    for seed in 1..=4 {
        let d = input.join(format!("f{seed}"));
        let scenario = fixture("scenario_small.toml");
        let s = seed.to_string();
        succeeds(&ppkat(&[
            "simulate",
            "--scenario",
            p(&scenario),
            "--seed",
            &s,
            "-o",
            p(&d),
        ]));
        made.push(d);
    }
    let slow = input.join("slow");
    succeeds(&ppkat(&[
        "simulate",
        "--scenario",
        p(&long_path),
        "-o",
        p(&slow),
    ]));
    made.push(slow);
    for d in &made {
        for extra in ["ground_points.csv", "image_observations.csv", "camera.toml"] {
            let _ = std::fs::remove_file(d.join(extra));
        }
    }
    let b = input.join("broken");
    std::fs::create_dir_all(&b).unwrap();
    std::fs::copy(input.join("f1/rover.obs"), b.join("rover.obs")).unwrap();
    input
}

#[test]
fn a_plan_runs_on_slurm_as_it_runs_here_and_a_cancelled_task_runs_again() {
    let Some(c) = Cluster::up() else {
        return;
    };
    let root = tmp("slurm");
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let input = flights(&root);
    let (out, here) = (root.join("out"), root.join("here"));

    // Here, as one machine runs them.
    let o = ppkat(&["batch", p(&input), "-o", p(&out), "--jobs", "2"]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    std::fs::rename(&out, &here).unwrap();

    // On the cluster: the plan, the array and the merge after it.
    let sub = c
        .command(env!("CARGO_BIN_EXE_ppkat"))
        .args(["batch", p(&input), "-o", p(&out), "--slurm", "--submit"])
        .args(["--max-parallel", "2"])
        .output()
        .unwrap();
    let t = text(&sub);
    assert_eq!(
        sub.status.code(),
        Some(3),
        "the broken flight is named: {t}"
    );
    assert!(t.contains("flight broken") && t.contains("no base"), "{t}");
    let job = t
        .split("submitted: array job ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .unwrap_or_else(|| panic!("no job id: {t}"))
        .to_string();
    let plan = std::fs::read_to_string(out.join("plan.tsv")).unwrap();
    let slow_index = plan
        .lines()
        .find(|l| l.split('\t').nth(1) == Some("slow"))
        .and_then(|l| l.split('\t').next())
        .expect("the long flight in the plan")
        .to_string();

    // Cancel the long flight's task while it runs.
    let status = out.join("status/slow.json");
    c.wait(
        "the long flight's task to start",
        Duration::from_secs(120),
        || status.exists(),
    );
    let cancel = c
        .command("scancel")
        .arg(format!("{job}_{slow_index}"))
        .output()
        .unwrap();
    assert!(cancel.status.success(), "{}", text(&cancel));
    let summary = out.join("summary.csv");
    c.wait("the merge job", Duration::from_secs(180), || {
        summary.exists()
    });
    let sum = std::fs::read_to_string(&summary).unwrap();
    assert!(
        sum.contains("slow,NOT RUN") && sum.contains("broken,FAILED"),
        "{sum}"
    );
    let st = ppkat(&["batch", p(&input), "-o", p(&out), "--status"]);
    let st = succeeds(&st);
    assert!(
        st.contains("4 done") && st.contains("1 died") && st.contains("1 failed"),
        "{st}"
    );
    // Nothing of the cancelled flight looks whole: no result, no output but temporaries.
    let left: Vec<PathBuf> = files(&out.join("slow"));
    assert!(
        left.iter().all(|f| f.to_string_lossy().ends_with(".tmp")),
        "a cancelled task left {left:?}"
    );

    // Its task again, and the merge again.
    let again = c
        .command("sbatch")
        .args(["--parsable", &format!("--array={slow_index}")])
        .arg(out.join("slurm/batch.sbatch"))
        .output()
        .unwrap();
    assert!(again.status.success(), "{}", text(&again));
    let result = out.join("slow/result.json");
    c.wait(
        "the long flight run again",
        Duration::from_secs(180),
        || result.exists(),
    );
    let m = ppkat(&["batch", p(&input), "-o", p(&out), "--merge"]);
    assert_eq!(m.status.code(), Some(3), "{}", text(&m));
    assert!(text(&m).contains("flight broken: FAILED"), "{}", text(&m));

    // Every output as here, byte for byte; the results but their durations.
    let (ours, theirs) = (files(&here), files(&out));
    assert_eq!(ours, theirs, "the same files");
    assert!(ours.len() >= 20, "{ours:?}");
    for f in &ours {
        if f.ends_with("result.json") {
            assert_eq!(
                result_fields(&here.join(f)),
                result_fields(&out.join(f)),
                "{f:?}"
            );
        } else {
            let same = std::fs::read(here.join(f)).unwrap() == std::fs::read(out.join(f)).unwrap();
            assert!(same, "{f:?} differs between here and Slurm");
        }
    }
    let peak: Vec<String> = ["f1", "slow"]
        .iter()
        .map(|f| {
            let s: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(out.join(format!("status/{f}.json"))).unwrap(),
            )
            .unwrap();
            format!("{f}: {} s, {} KiB", s["wall_s"], s["peak_rss_kib"])
        })
        .collect();
    eprintln!("slurm tasks: {}", peak.join("; "));
}
