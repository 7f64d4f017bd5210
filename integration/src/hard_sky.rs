//! The `hard-sky` flight, ready to adjust both ways: the simulation (5–6 satellites, every
//! one lost at each turn and again 30–60 s into each strip, a base 20 km away), the PPK
//! trajectory, the camera stations, and two projects over the same data — `project.toml`
//! with `coupling = "loose"` (the PPK antenna positions) and `project_tight.toml` with
//! `coupling = "tight"` (the double-difference carrier phase and code of the rover and base
//! files, see [`crate::adjust::tight`]). Enters: a folder. Leaves: those files there (beside
//! the simulator's truth) and a [`HardSky`] report.

use crate::demo::{self, ChainError, SimInputs};
use crate::simulate::{self, SimReport};
use gnss::ppk::PpkOptions;
use gnss::solution::PosFormat;
use std::path::Path;

/// What the hard-sky preparation measured.
#[derive(Clone, Debug)]
pub struct HardSky {
    /// What the simulation wrote.
    pub sim: SimReport,
    /// Rover epochs solved by PPK.
    pub ppk_epochs: usize,
    /// Rover epochs PPK fixed.
    pub ppk_fixed: usize,
    /// Camera stations.
    pub stations: usize,
    /// Camera stations whose antenna position is not fixed (Q ≠ 1).
    pub stations_float: usize,
}

impl std::fmt::Display for HardSky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.sim)?;
        writeln!(
            f,
            "  PPK: {} epochs, {} fixed ({:.1} %); {} camera stations, {} of them float",
            self.ppk_epochs,
            self.ppk_fixed,
            100.0 * self.ppk_fixed as f64 / self.ppk_epochs.max(1) as f64,
            self.stations,
            self.stations_float
        )?;
        writeln!(
            f,
            "  adjust both ways: ppkat adjust {0}/project.toml and {0}/project_tight.toml",
            self.sim.dir.display()
        )
    }
}

/// Simulate the hard-sky flight into `out`, run PPK and the exposures, and write both
/// projects.
pub fn run(out: &Path) -> Result<HardSky, ChainError> {
    let scenario = simulate::builtin("hard-sky").ok_or_else(|| ChainError::Truth {
        path: "hard-sky".into(),
        what: "the built-in scenario is missing".into(),
    })?;
    run_scenario(out, &scenario)
}

/// [`run`] for another scenario of the same kind (a shorter one for tests).
pub fn run_scenario(out: &Path, scenario: &simulate::Scenario) -> Result<HardSky, ChainError> {
    let scenario = scenario.clone();
    let sim = simulate::run(&scenario, out)?;
    let inputs = SimInputs::read(&sim)?;
    let res = inputs.ppk(&sim, &PpkOptions::default())?;
    res.trajectory.write_pos(
        &out.join("rover_ppk.pos"),
        &["program   : ppkat simulate --builtin hard-sky (carrier-phase kinematic)".into()],
        PosFormat::Llh,
    )?;
    let ex = demo::exposures(out, &scenario, &inputs.rover, &res.trajectory)?;
    demo::write_adjust_project(out, &scenario, &ex.stations)?;
    let loose = std::fs::read_to_string(out.join("project.toml"))
        .map_err(gnss::Error::io(&out.join("project.toml")))?;
    let b = sim.base_position.0;
    let tight = format!(
        "{loose}coupling = \"tight\"\nrover = \"rover.obs\"\nbase = \"base.obs\"\nnav = \"nav.rnx\"\nbase_position = [{:.4}, {:.4}, {:.4}]\n",
        b.x, b.y, b.z
    );
    let perfect = loose.replace("antennas.csv", "antennas_perfect.csv");
    write_perfect(out)?;
    for (name, text) in [
        ("project.toml", format!("{loose}coupling = \"loose\"\n")),
        ("project_tight.toml", tight),
        (
            "project_perfect.toml",
            format!("{perfect}coupling = \"loose\"\n"),
        ),
    ] {
        common::atomic::write_atomic(&out.join(name), |w| w.write_all(text.as_bytes()))?;
    }
    Ok(HardSky {
        ppk_epochs: res.trajectory.epochs.len(),
        ppk_fixed: res.fixed(),
        stations: ex.stations.len(),
        stations_float: ex
            .stations
            .iter()
            .filter(|s| s.quality != gnss::solution::Quality::Fixed)
            .count(),
        sim,
    })
}

/// `antennas_perfect.csv`: the antenna table with the true antenna positions at the
/// exposures, fixed, σ 1 cm horizontal and 2 cm up — GNSS as good as it gets, for comparison.
fn write_perfect(out: &Path) -> Result<(), ChainError> {
    let read = |name: &str| {
        std::fs::read_to_string(out.join(name)).map_err(|e| ChainError::Truth {
            path: out.join(name).display().to_string(),
            what: e.to_string(),
        })
    };
    let (table, truth) = (read("antennas.csv")?, read("truth_exposures.csv")?);
    let true_antenna: std::collections::BTreeMap<&str, gnss::frame::Ecef> = truth
        .lines()
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let v = |i: usize| f.get(i)?.parse::<f64>().ok();
            let p = nalgebra::Vector3::new(v(7)?, v(8)?, v(9)?);
            Some((f[0], gnss::frame::Ecef(p)))
        })
        .collect();
    let mut text = String::new();
    for l in table.lines() {
        let f: Vec<&str> = l.split(',').collect();
        match true_antenna.get(f[0]) {
            Some(p) if f.len() >= 14 => {
                let g = p.to_geodetic();
                let rest: String = f[14..].iter().map(|x| format!(",{x}")).collect();
                text += &format!(
                    "{},{},{},{:.10},{:.10},{:.4},0.0001,0,0,0.0001,0,0.0004,1,0{rest}\n",
                    f[0],
                    f[1],
                    f[2],
                    g.lat.to_degrees(),
                    g.lon.to_degrees(),
                    g.h
                );
            }
            _ => text += &format!("{l}\n"),
        }
    }
    common::atomic::write_atomic(&out.join("antennas_perfect.csv"), |w| {
        w.write_all(text.as_bytes())
    })?;
    Ok(())
}
