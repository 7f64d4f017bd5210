//! `ppkat batch` across machines: the plan (a line per flight: its index, name, what is wrong
//! with it if anything, the command a scheduler's task runs and the outputs it will write),
//! each task's result and status files, and what the merge and the status view make of them.
//!
//! Everything lives in the output folder, on the shared filesystem every task sees:
//! `plan.tsv`, `FLIGHT/result.json` (the flight's summary row and report, written last and
//! whole: a flight without it did not finish) and `status/FLIGHT.json` (started, finished,
//! exit code, wall time, peak memory, where). Reading them twice gives the same merge: a
//! merge or a task may be run again at any time.

use crate::batch::{Outcome, SummaryRow};
use gnss::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The plan's file name in the output folder.
pub const PLAN: &str = "plan.tsv";
/// A flight's result file name in its output folder.
pub const RESULT: &str = "result.json";
/// The folder of the tasks' status files in the output folder.
pub const STATUS_DIR: &str = "status";

/// One flight of the plan.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanEntry {
    /// The task index that runs it (0-based, the flights in name order).
    pub index: usize,
    /// The flight's name (its folder's).
    pub flight: String,
    /// Why it cannot run as it is (its task fails with this), if anything.
    pub problem: Option<String>,
    /// The command its task runs.
    pub command: String,
    /// The files its task writes.
    pub outputs: Vec<PathBuf>,
}

/// The plan of a batch: the input and output folders and the flights.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// The folder of flights.
    pub root: PathBuf,
    /// The output folder.
    pub out: PathBuf,
    /// The flights, by index.
    pub entries: Vec<PlanEntry>,
}

const HEADER: &str = "index\tflight\tproblem\tcommand\toutputs…";

/// Write `text` to `path` whole or not at all, its folder made first.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|cause| Error::Write {
            path: dir.to_path_buf(),
            cause,
        })?;
    }
    common::atomic::write_atomic(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}

/// A field of the plan: no tab nor line break inside.
fn field(s: &str, what: &str) -> Result<String> {
    if s.contains(['\t', '\n', '\r']) {
        return Err(Error::NoData(format!(
            "{what} {s:?} holds a tab or a line break: rename it to write a plan"
        )));
    }
    Ok(s.to_string())
}

impl Plan {
    /// The plan as text: a first line naming the folders, a header, a line per flight.
    pub fn to_tsv(&self) -> Result<String> {
        let mut s = format!(
            "# ppkat batch plan\troot={}\tout={}\n{HEADER}\n",
            field(&self.root.to_string_lossy(), "the folder")?,
            field(&self.out.to_string_lossy(), "the folder")?
        );
        for e in &self.entries {
            let mut cols = vec![
                e.index.to_string(),
                field(&e.flight, "the flight")?,
                field(e.problem.as_deref().unwrap_or(""), "the problem")?,
                field(&e.command, "the command")?,
            ];
            for o in &e.outputs {
                cols.push(field(&o.to_string_lossy(), "the output")?);
            }
            s.push_str(&cols.join("\t"));
            s.push('\n');
        }
        Ok(s)
    }

    /// Write the plan into its output folder (whole or not at all).
    pub fn write(&self) -> Result<PathBuf> {
        let path = self.out.join(PLAN);
        write_text(&path, &self.to_tsv()?)?;
        Ok(path)
    }

    /// Read the plan of the output folder `out`.
    pub fn read(out: &Path) -> Result<Plan> {
        let path = out.join(PLAN);
        let bad = |line: usize, what: &str| Error::Parse {
            path: path.clone(),
            line,
            what: format!(
                "{what}; write the plan again with `ppkat batch DIR -o {} --plan`",
                out.display()
            ),
        };
        let text = std::fs::read_to_string(&path).map_err(|e| Error::Input {
            path: path.clone(),
            what: format!(
                "{e}: no plan in this output folder; write it with `ppkat batch DIR -o {} --plan`",
                out.display()
            ),
        })?;
        let mut lines = text.lines();
        let first: Vec<&str> = lines.next().unwrap_or("").split('\t').collect();
        let folder = |key: &str| {
            first
                .iter()
                .find_map(|c| c.strip_prefix(key))
                .map(PathBuf::from)
                .ok_or_else(|| bad(1, "not a ppkat batch plan"))
        };
        let (root, planned_out) = (folder("root=")?, folder("out=")?);
        if lines.next() != Some(HEADER) {
            return Err(bad(2, "not the plan's header"));
        }
        let mut entries = Vec::new();
        for (i, l) in lines.enumerate() {
            let c: Vec<&str> = l.split('\t').collect();
            let index: usize = c[0].parse().map_err(|_| bad(i + 3, "no index"))?;
            if c.len() < 4 || index != entries.len() {
                return Err(bad(i + 3, "a flight's line is cut or out of order"));
            }
            entries.push(PlanEntry {
                index,
                flight: c[1].to_string(),
                problem: (!c[2].is_empty()).then(|| c[2].to_string()),
                command: c[3].to_string(),
                outputs: c[4..].iter().map(PathBuf::from).collect(),
            });
        }
        Ok(Plan {
            root,
            out: planned_out,
            entries,
        })
    }

    /// The entry of a flight by its name.
    pub fn by_name(&self, flight: &str) -> Option<&PlanEntry> {
        self.entries.iter().find(|e| e.flight == flight)
    }
}

/// What a flight's task leaves when it ends: its summary row and report text.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlightResult {
    /// The flight.
    pub flight: String,
    /// `done`, `skipped` or `failed`.
    pub outcome: String,
    /// Rover epochs read.
    pub epochs: usize,
    /// Epochs solved.
    pub solved: usize,
    /// Epochs fixed.
    pub fixed: usize,
    /// Median 3D σ, m (none when nothing was solved).
    pub sigma_3d_m: Option<f64>,
    /// Exposures written, when the flight had exposure times.
    pub exposures: Option<usize>,
    /// Warnings and skipped inputs.
    pub warnings: usize,
    /// The error or the first warning.
    pub message: String,
    /// The flight's report, as `ppkat batch` prints it.
    pub report: String,
}

impl FlightResult {
    /// The result of a run.
    pub fn new(row: &SummaryRow, report: &str) -> FlightResult {
        FlightResult {
            flight: row.flight.clone(),
            outcome: match row.outcome {
                Outcome::Done => "done",
                Outcome::Skipped => "skipped",
                Outcome::Failed | Outcome::NotRun => "failed",
            }
            .into(),
            epochs: row.epochs,
            solved: row.solved,
            fixed: row.fixed,
            sigma_3d_m: row.sigma_3d.is_finite().then_some(row.sigma_3d),
            exposures: row.exposures,
            warnings: row.warnings,
            message: row.message.clone(),
            report: report.to_string(),
        }
    }

    /// Its summary row.
    pub fn row(&self) -> SummaryRow {
        SummaryRow {
            flight: self.flight.clone(),
            outcome: match self.outcome.as_str() {
                "done" => Outcome::Done,
                "skipped" => Outcome::Skipped,
                _ => Outcome::Failed,
            },
            epochs: self.epochs,
            solved: self.solved,
            fixed: self.fixed,
            sigma_3d: self.sigma_3d_m.unwrap_or(f64::NAN),
            exposures: self.exposures,
            warnings: self.warnings,
            message: self.message.clone(),
        }
    }

    /// Write it as `out/FLIGHT/result.json` (whole or not at all).
    pub fn write(&self, out: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self).expect("a result serialises");
        write_text(&out.join(&self.flight).join(RESULT), &text)
    }

    /// The result of `flight` in `out`, None when its task has not finished.
    pub fn read(out: &Path, flight: &str) -> Result<Option<FlightResult>> {
        let path = out.join(flight).join(RESULT);
        match std::fs::read_to_string(&path) {
            Ok(t) => serde_json::from_str(&t)
                .map(Some)
                .map_err(|e| Error::Input {
                    what: format!("{e}: not a flight's result; run its task again"),
                    path,
                }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(cause) => Err(Error::Io { path, cause }),
        }
    }
}

/// A task's status file: written when it starts and again when it ends.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TaskStatus {
    /// The flight.
    pub flight: String,
    /// Its index in the plan.
    pub index: usize,
    /// The machine it runs on.
    pub host: String,
    /// Its process id there.
    pub pid: u32,
    /// When it started, seconds since 1970 (UTC).
    pub started_unix_s: f64,
    /// When it ended, if it has.
    pub finished_unix_s: Option<f64>,
    /// Its exit code, if it has ended (0 done, 3 skipped inputs, 1 failed).
    pub exit_code: Option<i32>,
    /// Wall time, s, if it has ended.
    pub wall_s: Option<f64>,
    /// Peak resident memory, KiB, if it has ended.
    pub peak_rss_kib: Option<u64>,
}

impl TaskStatus {
    /// The status file of `flight` in `out`.
    pub fn path(out: &Path, flight: &str) -> PathBuf {
        out.join(STATUS_DIR).join(format!("{flight}.json"))
    }

    /// Write it (whole or not at all).
    pub fn write(&self, out: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self).expect("a status serialises");
        write_text(&TaskStatus::path(out, &self.flight), &text)
    }

    /// The status of `flight` in `out`, None when its task never started (or the file is
    /// not one).
    pub fn read(out: &Path, flight: &str) -> Option<TaskStatus> {
        let t = std::fs::read_to_string(TaskStatus::path(out, flight)).ok()?;
        serde_json::from_str(&t).ok()
    }
}

/// Where a flight of the plan stands.
#[derive(Clone, Debug, PartialEq)]
pub enum TaskState {
    /// Finished with a result: its row.
    Finished(SummaryRow),
    /// Started, no result yet.
    Running {
        /// The machine it runs on.
        host: String,
        /// Its process is known to be gone (on this machine, its process id no longer runs).
        gone: bool,
        /// Seconds since it started.
        since_s: f64,
    },
    /// Ended without a result (killed, or out of memory): its exit code if it wrote one.
    Died(Option<i32>),
    /// Never started.
    NotStarted,
}

/// Where the flight of `e` stands in `out`, now being `now_unix_s`.
pub fn task_state(out: &Path, e: &PlanEntry, now_unix_s: f64) -> Result<TaskState> {
    if let Some(r) = FlightResult::read(out, &e.flight)? {
        return Ok(TaskState::Finished(r.row()));
    }
    Ok(match TaskStatus::read(out, &e.flight) {
        None => TaskState::NotStarted,
        Some(s) if s.finished_unix_s.is_some() => TaskState::Died(s.exit_code),
        Some(s) => {
            let here = this_host();
            let gone = s.host == here && !Path::new(&format!("/proc/{}", s.pid)).exists();
            TaskState::Running {
                host: s.host,
                gone,
                since_s: now_unix_s - s.started_unix_s,
            }
        }
    })
}

/// This machine's name (Linux: the kernel's hostname; "localhost" when unknown).
pub fn this_host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_string())
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "localhost".into())
}

/// The merge: a summary row per flight of the plan, in its order — its result's, or for a
/// flight without one a row saying what became of its task.
pub fn merge_rows(plan: &Plan) -> Result<Vec<(SummaryRow, Option<String>)>> {
    let mut rows = Vec::new();
    for e in &plan.entries {
        if let Some(r) = FlightResult::read(&plan.out, &e.flight)? {
            rows.push((r.row(), Some(r.report)));
            continue;
        }
        let why = match TaskStatus::read(&plan.out, &e.flight) {
            None => "never ran (no status, no result): run its task again".to_string(),
            Some(s) => format!(
                "its task on {} (pid {}) left no result{}: run it again",
                s.host,
                s.pid,
                s.exit_code
                    .map_or(" (killed, or still running)".into(), |c| format!(
                        " (exit {c})"
                    ))
            ),
        };
        rows.push((SummaryRow::empty(&e.flight, Outcome::NotRun, why), None));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plan_reads_back_as_written_and_refuses_what_it_cannot_hold() {
        let plan = Plan {
            root: "/data/in".into(),
            out: "/data/out".into(),
            entries: vec![
                PlanEntry {
                    index: 0,
                    flight: "a".into(),
                    problem: None,
                    command: "ppkat batch /data/in -o /data/out --only-index 0".into(),
                    outputs: vec!["/data/out/a/a.pos".into(), "/data/out/a/result.json".into()],
                },
                PlanEntry {
                    index: 1,
                    flight: "b c".into(),
                    problem: Some("no base file".into()),
                    command: "ppkat batch /data/in -o /data/out --only-index 1".into(),
                    outputs: vec![],
                },
            ],
        };
        let dir = std::env::temp_dir().join(format!("ppkat-plan-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut p = plan.clone();
        p.out = dir.clone();
        p.write().unwrap();
        assert_eq!(Plan::read(&dir).unwrap(), p);
        p.entries[0].flight = "a\tb".into();
        assert!(p.to_tsv().unwrap_err().to_string().contains("tab"));
        std::fs::write(dir.join(PLAN), "nonsense\n").unwrap();
        let e = Plan::read(&dir).unwrap_err().to_string();
        assert!(e.contains("plan.tsv:1:") && e.contains("--plan"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn results_and_states_read_back_and_a_flight_without_result_is_named() {
        let dir = std::env::temp_dir().join(format!("ppkat-merge-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let entry = |i: usize, f: &str| PlanEntry {
            index: i,
            flight: f.into(),
            problem: None,
            command: String::new(),
            outputs: vec![],
        };
        let plan = Plan {
            root: "/in".into(),
            out: dir.clone(),
            entries: vec![entry(0, "done"), entry(1, "running"), entry(2, "never")],
        };
        let row = SummaryRow {
            flight: "done".into(),
            outcome: Outcome::Done,
            epochs: 10,
            solved: 9,
            fixed: 8,
            sigma_3d: 0.0123,
            exposures: Some(3),
            warnings: 0,
            message: String::new(),
        };
        FlightResult::new(&row, "report\n").write(&dir).unwrap();
        let status = TaskStatus {
            flight: "running".into(),
            index: 1,
            host: this_host(),
            pid: std::process::id(),
            started_unix_s: 100.0,
            finished_unix_s: None,
            exit_code: None,
            wall_s: None,
            peak_rss_kib: None,
        };
        status.write(&dir).unwrap();
        let rows = merge_rows(&plan).unwrap();
        assert_eq!(rows[0].0, row);
        assert_eq!(rows[0].1.as_deref(), Some("report\n"));
        assert_eq!(rows[1].0.outcome, Outcome::NotRun);
        assert!(rows[1].0.message.contains("left no result"));
        assert!(rows[2].0.message.contains("never ran"));
        assert!(matches!(
            task_state(&dir, &plan.entries[1], 130.0).unwrap(),
            TaskState::Running { gone: false, since_s, .. } if since_s == 30.0
        ));
        assert_eq!(
            task_state(&dir, &plan.entries[2], 130.0).unwrap(),
            TaskState::NotStarted
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
