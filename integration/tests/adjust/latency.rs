//! The GNSS latency on the classic block (whose GNSS has none): from a trajectory (velocity
//! from the interpolation) it comes out zero within its σ, per block or per flight; a prior
//! holds it; an antenna table without velocities is refused with what to do.

use super::*;

/// The classic project on its trajectory with the given extra `[gnss]` lines.
fn classic_with(name: &str, trajectory: bool, gnss: &str) -> std::path::PathBuf {
    let dir = project_dir(name);
    edit(&dir, "project.toml", |t| {
        let t = t.replace(
            "drift_model = \"linear\"\n",
            &format!("drift_model = \"linear\"\n{gnss}"),
        );
        if trajectory {
            t.replace(
                "antennas = \"antennas.csv\"",
                "trajectory = \"trajectory.pos\"",
            )
        } else {
            t
        }
    });
    dir
}

fn adjusted(dir: &std::path::Path) -> Results {
    adjust::run(
        &dir.join("project.toml"),
        &dir.join("out"),
        &Default::default(),
    )
    .unwrap()
}

/// No latency simulated: the estimate is zero within 3σ, σ a few ms at 70 m/s and 5 cm
/// GNSS; reported in report.json, parameters.csv and the HTML report.
#[test]
fn classic_block_latency_is_zero_within_its_sigma() {
    let dir = classic_with("lat-zero", true, "latency = \"block\"\n");
    let r = adjusted(&dir);
    assert_eq!(r.latencies.len(), 1);
    let l = &r.latencies[0];
    println!("classic latency {:.5} ± {:.5} s", l.values[0], l.sigmas[0]);
    assert_eq!(l.name, "GNSS latency (block)");
    assert_eq!(l.labels, vec!["dt".to_string()]);
    assert!(l.sigmas[0] > 0.0 && l.sigmas[0] < 0.01, "{l:?}");
    assert!(l.values[0].abs() < 3.0 * l.sigmas[0], "{l:?}");
    let json = std::fs::read_to_string(dir.join("out/report.json")).unwrap();
    assert!(json.contains("\"latencies\"") && json.contains("GNSS latency (block)"));
    let csv = std::fs::read_to_string(dir.join("out/parameters.csv")).unwrap();
    assert!(
        csv.lines()
            .any(|x| x.starts_with("latency,\"GNSS latency (block)\",dt,") && x.contains(",s,")),
        "{csv}"
    );
    let html = std::fs::read_to_string(dir.join("out/report.html")).unwrap();
    assert!(html.contains("GNSS latency (block)"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Per flight: the classic block's strips are 150 s apart, one flight; a tight prior (its
/// mean half a data σ from the data's estimate) holds the latency at its start value.
#[test]
fn latency_per_flight_and_with_a_prior() {
    let dir = classic_with("lat-flight", true, "latency = \"flight\"\n");
    let r = adjusted(&dir);
    assert_eq!(r.latencies.len(), 1);
    assert_eq!(r.latencies[0].name, "GNSS latency (flight 1)");
    let dir2 = classic_with(
        "lat-prior",
        true,
        "latency = \"block\"\nlatency_start = 0.0005\nlatency_sigma = 0.00005\n",
    );
    let r = adjusted(&dir2);
    let l = &r.latencies[0];
    assert!(
        (l.values[0] - 0.0005).abs() < 2e-5 && l.sigmas[0] <= 5e-5,
        "{l:?}"
    );
    for d in [dir, dir2] {
        let _ = std::fs::remove_dir_all(&d);
    }
}

/// An antenna table without `ve,vn,vu` cannot carry a latency: refused, saying what to do.
#[test]
fn latency_without_velocities_is_refused() {
    let dir = classic_with("lat-novel", false, "latency = \"block\"\n");
    let e = fails(&dir);
    assert!(
        e.contains("latency = \"block\" needs the antenna velocity") && e.contains("ve,vn,vu"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
