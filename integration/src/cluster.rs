//! A batch plan ([`crate::batch_plan`]) on the schedulers clusters already have: a Slurm job
//! array with a merge job after it, and a Kubernetes Indexed Job with a merge Job. Only text
//! is made here; the command line writes it, and submits the Slurm scripts when asked.

use crate::batch::Flight;
use crate::batch_plan::Plan;
use gnss::error::{Error, Result};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// What each task asks of a node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaskResources {
    /// CPUs.
    pub cpus: u16,
    /// Memory, MB.
    pub mem_mb: u32,
}

/// Memory a flight's task asks for, MB, from its observation files: 512 MB and 40 times
/// their size (a gzip or Hatanaka file counted 8 times its size), rounded up to 256 MB.
pub fn flight_mem_mb(f: &Flight) -> u32 {
    let files = f.rover.iter().chain(f.base.iter()).chain(f.nav.iter());
    let bytes: u64 = files
        .map(|p| {
            let size = std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
            let name = p.to_string_lossy().to_ascii_lowercase();
            let b = name.as_bytes();
            let hatanaka_2 = b.len() > 4
                && b[b.len() - 4] == b'.'
                && b[b.len() - 3..b.len() - 1].iter().all(u8::is_ascii_digit)
                && b[b.len() - 1] == b'd';
            let packed = hatanaka_2 || [".gz", ".z", ".crx"].iter().any(|e| name.ends_with(e));
            if packed {
                8 * size
            } else {
                size
            }
        })
        .sum();
    let mb = 512 + (40 * bytes).div_ceil(1 << 20);
    (mb.div_ceil(256) * 256).min(u64::from(u32::MAX)) as u32
}

/// A word for a POSIX shell, single-quoted.
pub fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

/// How the Slurm scripts run the plan.
#[derive(Clone, Debug)]
pub struct SlurmOptions {
    /// The `ppkat` binary every node runs (on the shared filesystem or installed alike).
    pub ppkat: PathBuf,
    /// Tasks running at once.
    pub max_parallel: u16,
    /// What each task asks for.
    pub resources: TaskResources,
    /// More `#SBATCH` options, as given.
    pub extra: Vec<String>,
}

/// The job array script (a task per flight of the plan) and the merge script.
pub fn slurm_scripts(plan: &Plan, o: &SlurmOptions) -> (String, String) {
    let q = |p: &Path| shell_quote(&p.to_string_lossy());
    let logs = plan.out.join("logs");
    let extra: String = o.extra.iter().map(|e| format!("#SBATCH {e}\n")).collect();
    let last = plan.entries.len().saturating_sub(1);
    let array = format!(
        "#!/bin/bash\n\
         # ppkat batch: a task per flight of {plan_path} ({n} flights), written by ppkat batch --slurm.\n\
         # Task i runs the flight of index i; its outputs, result.json and status file go to the\n\
         # output folder on the shared filesystem. Merge after it: merge.sbatch.\n\
         #SBATCH --job-name=ppkat-batch\n\
         #SBATCH --array=0-{last}%{m}\n\
         #SBATCH --ntasks=1\n\
         #SBATCH --cpus-per-task={c}\n\
         #SBATCH --mem={mem}M\n\
         #SBATCH --output={log}\n\
         {extra}\
         exec {ppkat} --quiet --threads \"${{SLURM_CPUS_PER_TASK:-{c}}}\" batch {root} -o {out} --only-index \"$SLURM_ARRAY_TASK_ID\"\n",
        plan_path = plan.out.join(crate::batch_plan::PLAN).display(),
        n = plan.entries.len(),
        m = o.max_parallel,
        c = o.resources.cpus,
        mem = o.resources.mem_mb,
        log = logs.join("task-%a.log").display(),
        ppkat = q(&o.ppkat),
        root = q(&plan.root),
        out = q(&plan.out),
    );
    let merge = format!(
        "#!/bin/bash\n\
         # ppkat batch: the summary of {n} flights from their results, after the array\n\
         # (sbatch --dependency=afterany:ARRAY_JOB merge.sbatch), written by ppkat batch --slurm.\n\
         #SBATCH --job-name=ppkat-merge\n\
         #SBATCH --ntasks=1\n\
         #SBATCH --cpus-per-task=1\n\
         #SBATCH --mem=512M\n\
         #SBATCH --output={log}\n\
         {extra}\
         exec {ppkat} --quiet batch {root} -o {out} --merge\n",
        n = plan.entries.len(),
        log = logs.join("merge.log").display(),
        ppkat = q(&o.ppkat),
        root = q(&plan.root),
        out = q(&plan.out),
    );
    (array, merge)
}

/// How the Kubernetes Jobs run the plan.
#[derive(Clone, Debug)]
pub struct K8sOptions {
    /// The container image holding `ppkat` on its PATH.
    pub image: String,
    /// The PersistentVolumeClaim holding the flights and the output folder.
    pub claim: String,
    /// The local folder the claim holds (mounted at `/data`).
    pub mount: PathBuf,
    /// Pods running at once.
    pub max_parallel: u16,
    /// What each pod asks for.
    pub resources: TaskResources,
}

/// Where the pods mount the claim.
pub const MOUNT: &str = "/data";

/// `path` as the pods see it: under [`MOUNT`], from its place under the local mount.
fn in_pod(path: &Path, mount: &Path) -> Result<String> {
    let rel = path.strip_prefix(mount).map_err(|_| Error::Input {
        path: path.to_path_buf(),
        what: format!(
            "not inside {} (the folder the volume claim holds): give --mount a folder holding \
             both the flights and the output folder",
            mount.display()
        ),
    })?;
    Ok(Path::new(MOUNT).join(rel).to_string_lossy().into_owned())
}

/// A container of the Jobs: ppkat with `args`, the claim at [`MOUNT`], the resources.
fn container(o: &K8sOptions, args: Vec<String>, r: TaskResources) -> Value {
    let mem = format!("{}Mi", r.mem_mb);
    json!({
        "name": "ppkat",
        "image": o.image,
        "command": ["ppkat"],
        "args": args,
        "resources": {
            "requests": {"cpu": r.cpus.to_string(), "memory": mem},
            "limits": {"memory": mem}
        },
        "volumeMounts": [{"name": "data", "mountPath": MOUNT}]
    })
}

/// A Job manifest (batch/v1) with `spec` fields beside the pod template.
fn job(name: &str, mut spec: Value, pod: Value, o: &K8sOptions) -> Value {
    spec["template"] = json!({
        "metadata": {"labels": {"app": "ppkat", "ppkat-job": name}},
        "spec": {
            "restartPolicy": "Never",
            "containers": [pod],
            "volumes": [{"name": "data", "persistentVolumeClaim": {"claimName": o.claim}}]
        }
    });
    json!({
        "apiVersion": "batch/v1",
        "kind": "Job",
        "metadata": {"name": name, "labels": {"app": "ppkat"}},
        "spec": spec
    })
}

/// The Indexed Job (a pod per flight: `JOB_COMPLETION_INDEX` → `--only-index`, each index
/// retried once on its own) and the merge Job.
pub fn k8s_manifests(plan: &Plan, o: &K8sOptions) -> Result<(Value, Value)> {
    let (root, out) = (in_pod(&plan.root, &o.mount)?, in_pod(&plan.out, &o.mount)?);
    let n = plan.entries.len();
    let threads = o.resources.cpus.to_string();
    let task = container(
        o,
        [
            "--quiet",
            "--threads",
            &threads,
            "batch",
            &root,
            "-o",
            &out,
            "--only-index",
            "$(JOB_COMPLETION_INDEX)",
        ]
        .map(String::from)
        .to_vec(),
        o.resources,
    );
    let spec = json!({
        "completionMode": "Indexed",
        "completions": n,
        "parallelism": n.min(usize::from(o.max_parallel)),
        "backoffLimitPerIndex": 1,
        "maxFailedIndexes": n,
    });
    let batch = job("ppkat-batch", spec, task, o);
    let small = TaskResources {
        cpus: 1,
        mem_mb: 512,
    };
    let merge_args = ["--quiet", "batch", &root, "-o", &out, "--merge"]
        .map(String::from)
        .to_vec();
    let merge = job(
        "ppkat-merge",
        json!({"backoffLimit": 0}),
        container(o, merge_args, small),
        o,
    );
    Ok((batch, merge))
}

/// A manifest as the file holds it: indented JSON (which YAML readers take too), a final
/// line break.
pub fn manifest_text(v: &Value) -> String {
    serde_json::to_string_pretty(v).expect("a manifest serialises") + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::batch_plan::PlanEntry;

    /// The part of the Kubernetes API's batch/v1 Job schema the manifests use: each
    /// object's fields with their types (from the API reference: Job, JobSpec,
    /// PodTemplateSpec, PodSpec, Container, ResourceRequirements, VolumeMount, Volume,
    /// PersistentVolumeClaimVolumeSource, ObjectMeta).
    enum S {
        Str,
        Int,
        Strs,
        Labels,
        Quantities,
        List(&'static S),
        Obj(&'static [(&'static str, S)]),
    }

    const META: S = S::Obj(&[("name", S::Str), ("labels", S::Labels)]);
    const CONTAINER: S = S::Obj(&[
        ("name", S::Str),
        ("image", S::Str),
        ("command", S::Strs),
        ("args", S::Strs),
        (
            "resources",
            S::Obj(&[("requests", S::Quantities), ("limits", S::Quantities)]),
        ),
        (
            "volumeMounts",
            S::List(&S::Obj(&[("name", S::Str), ("mountPath", S::Str)])),
        ),
    ]);
    const VOLUME: S = S::Obj(&[
        ("name", S::Str),
        ("persistentVolumeClaim", S::Obj(&[("claimName", S::Str)])),
    ]);
    const JOB: S = S::Obj(&[
        ("apiVersion", S::Str),
        ("kind", S::Str),
        ("metadata", META),
        (
            "spec",
            S::Obj(&[
                ("completionMode", S::Str),
                ("completions", S::Int),
                ("parallelism", S::Int),
                ("backoffLimit", S::Int),
                ("backoffLimitPerIndex", S::Int),
                ("maxFailedIndexes", S::Int),
                (
                    "template",
                    S::Obj(&[
                        ("metadata", META),
                        (
                            "spec",
                            S::Obj(&[
                                ("restartPolicy", S::Str),
                                ("containers", S::List(&CONTAINER)),
                                ("volumes", S::List(&VOLUME)),
                            ]),
                        ),
                    ]),
                ),
            ]),
        ),
    ]);

    /// Where `v` breaks the schema `s`, by JSON path.
    fn check(v: &Value, s: &S, at: &str, errors: &mut Vec<String>) {
        let int32 = |v: &Value| v.as_i64().is_some_and(|i| i32::try_from(i).is_ok());
        let quantity = |v: &Value| {
            v.as_str().is_some_and(|q| {
                let digits = q.trim_end_matches("Mi");
                !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit())
            })
        };
        let ok = match s {
            S::Str => v.is_string(),
            S::Int => int32(v),
            S::Strs => v.as_array().is_some_and(|a| a.iter().all(Value::is_string)),
            S::Labels => v
                .as_object()
                .is_some_and(|m| m.values().all(Value::is_string)),
            S::Quantities => v.as_object().is_some_and(|m| {
                m.iter()
                    .all(|(k, q)| ["cpu", "memory"].contains(&k.as_str()) && quantity(q))
            }),
            S::List(item) => match v.as_array() {
                Some(a) => {
                    for (i, x) in a.iter().enumerate() {
                        check(x, item, &format!("{at}[{i}]"), errors);
                    }
                    true
                }
                None => false,
            },
            S::Obj(fields) => match v.as_object() {
                Some(m) => {
                    for (k, x) in m {
                        match fields.iter().find(|(name, _)| name == k) {
                            Some((_, f)) => check(x, f, &format!("{at}.{k}"), errors),
                            None => errors.push(format!("{at}.{k}: not a field of batch/v1")),
                        }
                    }
                    true
                }
                None => false,
            },
        };
        if !ok {
            errors.push(format!("{at}: wrong type: {v}"));
        }
    }

    /// A DNS-1123 label, as a Job's and a container's names must be.
    fn dns_label(s: &str) -> bool {
        let b = s.as_bytes();
        !b.is_empty()
            && b.len() <= 63
            && b.iter()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || *c == b'-')
            && b[0] != b'-'
            && b[b.len() - 1] != b'-'
    }

    #[test]
    fn the_kubernetes_manifests_hold_to_the_batch_v1_job_schema() {
        let entry = |i: usize| PlanEntry {
            index: i,
            flight: format!("f{i}"),
            problem: None,
            command: String::new(),
            outputs: vec![],
        };
        let plan = Plan {
            root: "/srv/survey/flights".into(),
            out: "/srv/survey/out".into(),
            entries: (0..40).map(entry).collect(),
        };
        let o = K8sOptions {
            image: "registry.example/ppkat:1.0".into(),
            claim: "survey".into(),
            mount: "/srv/survey".into(),
            max_parallel: 8,
            resources: TaskResources {
                cpus: 2,
                mem_mb: 1536,
            },
        };
        let (batch, merge) = k8s_manifests(&plan, &o).unwrap();
        for job in [&batch, &merge] {
            let mut errors = Vec::new();
            check(job, &JOB, "", &mut errors);
            assert!(errors.is_empty(), "{errors:?}");
            assert_eq!(job["apiVersion"], "batch/v1");
            assert_eq!(job["kind"], "Job");
            assert!(dns_label(job["metadata"]["name"].as_str().unwrap()));
            let pod = &job["spec"]["template"]["spec"];
            assert_eq!(pod["restartPolicy"], "Never");
            let c = &pod["containers"][0];
            assert!(dns_label(c["name"].as_str().unwrap()));
            assert_eq!(c["volumeMounts"][0]["name"], pod["volumes"][0]["name"]);
            assert_eq!(
                pod["volumes"][0]["persistentVolumeClaim"]["claimName"],
                "survey"
            );
        }
        let spec = &batch["spec"];
        assert_eq!(spec["completionMode"], "Indexed");
        assert_eq!(spec["completions"], 40);
        assert_eq!(spec["parallelism"], 8);
        // backoffLimitPerIndex needs Indexed and restartPolicy Never; maxFailedIndexes
        // needs backoffLimitPerIndex and at most the completions.
        assert_eq!(spec["backoffLimitPerIndex"], 1);
        assert!(spec["maxFailedIndexes"].as_i64().unwrap() <= 40);
        let args: Vec<&str> = spec["template"]["spec"]["containers"][0]["args"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| a.as_str().unwrap())
            .collect();
        assert_eq!(
            args,
            [
                "--quiet",
                "--threads",
                "2",
                "batch",
                "/data/flights",
                "-o",
                "/data/out",
                "--only-index",
                "$(JOB_COMPLETION_INDEX)"
            ]
        );
        let res = &spec["template"]["spec"]["containers"][0]["resources"];
        assert_eq!(res["requests"]["memory"], "1536Mi");
        assert_eq!(
            merge["spec"]["template"]["spec"]["containers"][0]["args"][5],
            "--merge"
        );
        // A folder outside the claim is refused, naming --mount.
        let outside = K8sOptions {
            mount: "/elsewhere".into(),
            ..o
        };
        let e = k8s_manifests(&plan, &outside).unwrap_err().to_string();
        assert!(e.contains("--mount"), "{e}");
        // The checker itself catches a field batch/v1 does not have.
        let mut bad = batch.clone();
        bad["spec"]["parallelizm"] = json!(2);
        let mut errors = Vec::new();
        check(&bad, &JOB, "", &mut errors);
        assert_eq!(errors, [".spec.parallelizm: not a field of batch/v1"]);
    }

    #[test]
    fn words_are_quoted_for_the_shell() {
        assert_eq!(shell_quote("/a b/c"), "'/a b/c'");
        assert_eq!(shell_quote("it's"), "'it'\\''s'");
    }
}
