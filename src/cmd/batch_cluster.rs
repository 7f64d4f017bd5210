//! `ppkat batch` across machines: the plan, one flight as a scheduler's task, the merge, the
//! status view, and the Slurm and Kubernetes files ([`integration::batch_plan`],
//! [`integration::cluster`]).

use super::batch_flight as b;
use anyhow::{bail, Context, Result};
use integration::batch::{self, find_flight, find_flights, Outcome};
use integration::batch_plan::{self as bp, FlightResult, Plan, PlanEntry, TaskState, TaskStatus};
use integration::cluster::{self, K8sOptions, SlurmOptions, TaskResources};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

/// Seconds since 1970.
fn now() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// `dir` made absolute, without resolving links (the shared filesystem's path as given).
fn absolute(dir: &Path) -> Result<PathBuf> {
    std::path::absolute(dir).with_context(|| format!("{}: cannot make it absolute", dir.display()))
}

/// What is wrong with a flight, if anything: its options files, its open questions, its
/// inputs (each opened and read), its command lines as the CLI parses them.
fn check_flight(f: &batch::Flight, out: &Path) -> Result<Vec<PathBuf>> {
    let (ppk_keys, exp_keys) = b::settled_keys(f)?;
    let inputs = [&f.rover, &f.base, &f.mrk]
        .into_iter()
        .flatten()
        .chain(&f.nav);
    for p in inputs {
        use std::io::Read;
        let mut one = [0u8; 1];
        std::fs::File::open(p)
            .and_then(|mut h| h.read(&mut one))
            .with_context(|| format!("{}: cannot read", p.display()))?;
    }
    let dir = out.join(&f.name);
    let mut notes = String::new();
    b::parse(b::ppk_argv(f, &ppk_keys, &dir), &mut notes)?;
    let pos = dir.join(format!("{}.pos", f.name));
    let mut outputs = vec![pos.clone(), dir.join(format!("{}.html", f.name))];
    if let Some(argv) = b::exposures_argv(f, &exp_keys, &pos, &dir) {
        b::parse(argv, &mut notes)?;
        outputs.push(dir.join("exposures.csv"));
    }
    outputs.push(dir.join(bp::RESULT));
    Ok(outputs)
}

/// The plan of `dir`'s flights with outputs in `out` (created), every flight checked, and
/// the flights found.
pub fn make_plan(dir: &Path, out: &Path) -> Result<(Plan, Vec<batch::Flight>)> {
    let flights = find_flights(&absolute(dir)?)?;
    if flights.is_empty() {
        bail!(
            "{}: no flight subfolders (a subfolder holding rover and base observation files)",
            dir.display()
        );
    }
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create the output folder", out.display()))?;
    let (root, out) = (absolute(dir)?, absolute(out)?);
    let mut seen: BTreeMap<String, String> = BTreeMap::new();
    let mut entries = Vec::new();
    for (index, f) in flights.iter().enumerate() {
        let command = format!(
            "ppkat batch {} -o {} --only-index {index}",
            cluster::shell_quote(&root.to_string_lossy()),
            cluster::shell_quote(&out.to_string_lossy())
        );
        let mut problem = None;
        let lower = f.name.to_lowercase();
        if let Some(other) = seen.insert(lower, f.name.clone()) {
            problem = Some(format!(
                "its outputs would collide with flight {other}'s on a case-blind filesystem: rename one folder"
            ));
        } else if out.starts_with(absolute(&f.dir)?) {
            problem = Some("the output folder lies inside it: write the outputs elsewhere".into());
        }
        let outputs = match check_flight(f, &out) {
            Ok(o) => o,
            Err(e) => {
                problem.get_or_insert(format!("{e:#}").replace('\n', " "));
                Vec::new()
            }
        };
        entries.push(PlanEntry {
            index,
            flight: f.name.clone(),
            problem,
            command,
            outputs,
        });
    }
    Ok((Plan { root, out, entries }, flights))
}

/// What `--plan`, `--slurm` and `--k8s` were given.
pub struct Scheduler<'a> {
    /// The folder of flights.
    pub dir: &'a Path,
    /// The output folder.
    pub out: &'a Path,
    /// Write the Slurm scripts.
    pub slurm: bool,
    /// Submit them.
    pub submit: bool,
    /// Write the Kubernetes manifests.
    pub k8s: bool,
    /// Tasks at once.
    pub max_parallel: Option<u16>,
    /// CPUs per task.
    pub cpus_per_task: Option<u16>,
    /// Memory per task, MB.
    pub mem_per_task: Option<u32>,
    /// More `#SBATCH` options.
    pub sbatch_option: &'a [String],
    /// The container image.
    pub image: &'a str,
    /// The volume claim.
    pub claim: &'a str,
    /// The local folder the claim holds.
    pub mount: Option<&'a Path>,
}

/// `--plan`, `--slurm`, `--k8s`: the plan, then the scheduler's files.
pub fn plan_and_scripts(args: &Scheduler) -> Result<()> {
    let (plan, flights) = make_plan(args.dir, args.out)?;
    let path = plan.write()?;
    let bad: Vec<String> = plan
        .entries
        .iter()
        .filter_map(|e| Some(format!("flight {}: {}", e.flight, e.problem.as_ref()?)))
        .collect();
    println!(
        "batch plan: {} flights, {} can run, {} cannot (their tasks will fail saying why) → {}",
        plan.entries.len(),
        plan.entries.len() - bad.len(),
        bad.len(),
        path.display()
    );
    let resources = TaskResources {
        cpus: args.cpus_per_task.unwrap_or(1),
        mem_mb: args.mem_per_task.unwrap_or_else(|| {
            flights
                .iter()
                .map(cluster::flight_mem_mb)
                .max()
                .unwrap_or(512)
        }),
    };
    let parallel = args.max_parallel.unwrap_or(16);
    if args.slurm {
        slurm(&plan, args, resources, parallel)?;
    }
    if args.k8s {
        k8s(&plan, args, resources, parallel)?;
    }
    super::complete(bad)
}

/// The Slurm scripts, and their submission with `--submit`.
fn slurm(plan: &Plan, args: &Scheduler, resources: TaskResources, parallel: u16) -> Result<()> {
    let o = SlurmOptions {
        ppkat: std::env::current_exe().context("cannot tell where this ppkat binary is")?,
        max_parallel: parallel,
        resources,
        extra: args.sbatch_option.to_vec(),
    };
    let (array, merge) = cluster::slurm_scripts(plan, &o);
    let dir = plan.out.join("slurm");
    let (a, m) = (dir.join("batch.sbatch"), dir.join("merge.sbatch"));
    bp::write_text(&a, &array)?;
    bp::write_text(&m, &merge)?;
    std::fs::create_dir_all(plan.out.join("logs"))
        .with_context(|| format!("{}: cannot create", plan.out.join("logs").display()))?;
    println!(
        "slurm: a task per flight ({} CPU, {} MB each, {} at once) → {}; the merge after it → {}",
        resources.cpus,
        resources.mem_mb,
        parallel,
        a.display(),
        m.display()
    );
    if !args.submit {
        println!(
            "  submit: JOB=$(sbatch --parsable {}) && sbatch --dependency=afterany:$JOB {}",
            a.display(),
            m.display()
        );
        return Ok(());
    }
    let job = sbatch(&[a.as_os_str()])?;
    let dep = format!("--dependency=afterany:{job}");
    let merge_job = sbatch(&[std::ffi::OsStr::new(&dep), m.as_os_str()])?;
    println!(
        "  submitted: array job {job} ({} tasks), merge job {merge_job} after it; watch with `ppkat batch {} -o {} --status`",
        plan.entries.len(),
        args.dir.display(),
        args.out.display()
    );
    Ok(())
}

/// `sbatch --parsable ARGS`: the job id.
fn sbatch(args: &[&std::ffi::OsStr]) -> Result<String> {
    let o = std::process::Command::new("sbatch")
        .arg("--parsable")
        .args(args)
        .output()
        .context("cannot run sbatch: submit from a machine of the Slurm cluster (sbatch on the PATH), or submit the scripts written yourself")?;
    if !o.status.success() {
        bail!(
            "sbatch refused the job: {}",
            String::from_utf8_lossy(&o.stderr).trim()
        );
    }
    let out = String::from_utf8_lossy(&o.stdout);
    let id = out.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() {
        bail!("sbatch gave no job id");
    }
    Ok(id)
}

/// The Kubernetes manifests, and the commands that would submit them.
fn k8s(plan: &Plan, args: &Scheduler, resources: TaskResources, parallel: u16) -> Result<()> {
    let mount = match args.mount {
        Some(m) => absolute(m)?,
        None => plan
            .root
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_else(|| plan.root.clone()),
    };
    let o = K8sOptions {
        image: args.image.to_string(),
        claim: args.claim.to_string(),
        mount,
        max_parallel: parallel,
        resources,
    };
    let (batch_job, merge_job) = cluster::k8s_manifests(plan, &o)?;
    let dir = plan.out.join("k8s");
    let (a, m) = (dir.join("batch-job.json"), dir.join("merge-job.json"));
    bp::write_text(&a, &cluster::manifest_text(&batch_job))?;
    bp::write_text(&m, &cluster::manifest_text(&merge_job))?;
    println!(
        "k8s: an Indexed Job of {} pods ({} CPU, {} Mi each, {} at once; image {}, claim {} at {} holding {}) → {}; the merge Job → {}",
        plan.entries.len(),
        resources.cpus,
        resources.mem_mb,
        parallel.min(plan.entries.len() as u16),
        o.image,
        o.claim,
        cluster::MOUNT,
        o.mount.display(),
        a.display(),
        m.display()
    );
    println!(
        "  would submit (nothing was): kubectl apply -f {} && kubectl wait --for=condition=complete --timeout=-1s job/ppkat-batch; kubectl apply -f {}",
        a.display(),
        m.display()
    );
    Ok(())
}

/// The plan of the output folder `out`, checked against the folder of flights `dir`.
fn read_plan(dir: &Path, out: &Path) -> Result<Plan> {
    let plan = Plan::read(out)?;
    let root = absolute(dir)?;
    if plan.root != root {
        bail!(
            "{}: the plan there was made for the flights of {}, not {}: give that folder, or write a new plan with --plan",
            out.join(bp::PLAN).display(),
            plan.root.display(),
            root.display()
        );
    }
    Ok(plan)
}

/// `--only-index` / `--only`: one flight as a scheduler's task.
pub fn task(dir: &Path, out: &Path, only_index: Option<usize>, only: Option<&str>) -> Result<()> {
    let t0 = Instant::now();
    let plan = read_plan(dir, out)?;
    let entry = match (&only_index, &only) {
        (Some(i), _) => plan.entries.get(*i).with_context(|| {
            format!(
                "--only-index {i}: the plan has flights 0 to {}",
                plan.entries.len().saturating_sub(1)
            )
        })?,
        (None, Some(name)) => plan
            .by_name(name)
            .with_context(|| format!("--only {name}: no such flight in the plan"))?,
        (None, None) => bail!("internal: no task"),
    };
    let _ = std::fs::remove_file(plan.out.join(&entry.flight).join(bp::RESULT));
    let mut status = TaskStatus {
        flight: entry.flight.clone(),
        index: entry.index,
        host: bp::this_host(),
        pid: std::process::id(),
        started_unix_s: now(),
        finished_unix_s: None,
        exit_code: None,
        wall_s: None,
        peak_rss_kib: None,
    };
    status.write(&plan.out)?;
    let done = match &entry.problem {
        Some(p) => failed(&entry.flight, p),
        None => match find_flight(&plan.root.join(&entry.flight)) {
            Ok(f) => b::run_flight(&f, &plan.out),
            Err(e) => failed(&entry.flight, &e.to_string()),
        },
    };
    print!("{}", done.text);
    FlightResult::new(&done.row, &done.text).write(&plan.out)?;
    let code = match done.row.outcome {
        Outcome::Done => 0,
        Outcome::Skipped => 3,
        Outcome::Failed | Outcome::NotRun => 1,
    };
    status.finished_unix_s = Some(now());
    status.exit_code = Some(code);
    status.wall_s = Some(t0.elapsed().as_secs_f64());
    status.peak_rss_kib = integration::bench::peak_rss_kib();
    status.write(&plan.out)?;
    match done.row.outcome {
        Outcome::Done => Ok(()),
        Outcome::Skipped => super::complete(vec![format!(
            "flight {}: skipped inputs: {}",
            entry.flight, done.row.message
        )]),
        _ => bail!("flight {}: {}", entry.flight, done.row.message),
    }
}

/// A flight that cannot run, as its task reports it.
fn failed(flight: &str, why: &str) -> b::Done {
    b::Done {
        row: batch::SummaryRow::empty(flight, Outcome::Failed, why.to_string()),
        text: format!("── flight {flight} ──\nerror: {why}\n"),
    }
}

/// `--merge`: the summary from the results, the flights without one named.
pub fn merge(dir: &Path, out: &Path) -> Result<()> {
    let t0 = Instant::now();
    let plan = read_plan(dir, out)?;
    let merged = bp::merge_rows(&plan)?;
    for (_, report) in &merged {
        if let Some(r) = report {
            print!("{r}");
        }
    }
    let rows: Vec<batch::SummaryRow> = merged.into_iter().map(|(r, _)| r).collect();
    let summary = plan.out.join("summary.csv");
    batch::write_summary(&summary, &rows)?;
    b::print_table(&rows, t0.elapsed().as_secs_f64(), &summary);
    b::verdict(&rows)
}

/// `--status`: where every flight stands.
pub fn status(dir: &Path, out: &Path) -> Result<()> {
    let plan = read_plan(dir, out)?;
    let t = now();
    let mut lines = Vec::new();
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for e in &plan.entries {
        let (word, detail) = match bp::task_state(&plan.out, e, t)? {
            TaskState::Finished(r) => {
                let w = match r.outcome {
                    Outcome::Done => "done",
                    Outcome::Skipped => "skipped inputs",
                    _ => "failed",
                };
                let said = r.message.lines().last().unwrap_or("").to_string();
                (w, if r.outcome == Outcome::Done { String::new() } else { said })
            }
            TaskState::Running { host, gone, since_s } if gone => (
                "died",
                format!("its process on {host} is gone ({since_s:.0} s after it started), no result: run its task again"),
            ),
            TaskState::Running { host, since_s, .. } => {
                ("running", format!("on {host} for {since_s:.0} s"))
            }
            TaskState::Died(code) => (
                "died",
                format!(
                    "ended{} without a result: run its task again",
                    code.map_or(String::new(), |c| format!(" with exit {c}"))
                ),
            ),
            TaskState::NotStarted => ("not started", String::new()),
        };
        *counts.entry(word).or_default() += 1;
        lines.push(format!(
            "  {:>5}  {:<20} {:<15} {}",
            e.index, e.flight, word, detail
        ));
    }
    let summary: Vec<String> = counts.iter().map(|(w, n)| format!("{n} {w}")).collect();
    println!(
        "batch status: {} flights: {} ({})",
        plan.entries.len(),
        summary.join(", "),
        out.join(bp::PLAN).display()
    );
    for l in lines {
        println!("{}", l.trim_end());
    }
    Ok(())
}
