//! Outputs that appear whole or not at all: a file is written to a hidden temporary beside it
//! and renamed over it; a folder is written into a hidden sibling folder and swapped in
//! (the old one renamed away, the new one renamed in, the old one removed). What a killed run
//! leaves behind (its temporaries, or a folder renamed away just before the swap) is cleaned
//! up, or put back, by the next run that writes the same output.
//!
//! Temporaries are named `.NAME.PID.tmp` (files), `.NAME.PID.spill` (a conversion's
//! intermediate file, where it cannot be unlinked while open), `.NAME.PID.new` and
//! `.NAME.PID.old` (folders); one whose process is gone is stale.

use std::io::Write;
use std::path::{Path, PathBuf};

/// What can go wrong while writing an output whole. The messages are those of the same
/// variants of `gnss::Error`, which converts from this one.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The output file could not be written.
    #[error("{path}: cannot write: {cause}; check that its folder exists and is writable")]
    Write {
        /// The file.
        path: PathBuf,
        /// What the system said.
        cause: std::io::Error,
    },
    /// The output as a whole is not what was asked for (a file where a folder is wanted, a
    /// folder holding files of others …).
    #[error("{path}: {what}")]
    Input {
        /// The file.
        path: PathBuf,
        /// What is wrong and what to do.
        what: String,
    },
}

/// Result of the writes of this module.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// An [`Error::Input`] about `path`.
    fn input(path: &Path, what: impl Into<String>) -> Self {
        Error::Input {
            path: path.to_path_buf(),
            what: what.into(),
        }
    }
}

/// The folder of `path` (`.` for a bare name) and its file name.
fn split(path: &Path) -> (PathBuf, String) {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    (dir.to_path_buf(), name)
}

/// The hidden sibling of `path` for this process, with `kind` (`tmp`, `spill`, `new`, `old`).
pub fn sibling(path: &Path, kind: &str) -> PathBuf {
    let (dir, name) = split(path);
    dir.join(format!(".{name}.{}.{kind}", std::process::id()))
}

/// Whether process `pid` still runs (where that can be told; elsewhere: no).
fn alive(pid: u32) -> bool {
    pid == std::process::id() || Path::new("/proc").join(pid.to_string()).exists()
}

/// Siblings of `path` of `kind` left by processes that are gone.
fn stale(path: &Path, kind: &str) -> Vec<PathBuf> {
    let (dir, name) = split(path);
    let (head, tail) = (format!(".{name}."), format!(".{kind}"));
    let Ok(rd) = std::fs::read_dir(&dir) else {
        return Vec::new();
    };
    rd.filter_map(|e| e.ok())
        .filter(|e| {
            let n = e.file_name().to_string_lossy().into_owned();
            n.strip_prefix(&head)
                .and_then(|r| r.strip_suffix(&tail))
                .and_then(|pid| pid.parse::<u32>().ok())
                .is_some_and(|pid| !alive(pid))
        })
        .map(|e| e.path())
        .collect()
}

/// A file beside an output: `OUT.pos` + `ext` (`.json`, `.html` …), the name every side
/// output of a run takes.
pub fn side_path(out: &Path, ext: &str) -> PathBuf {
    let mut name = out.as_os_str().to_owned();
    name.push(ext);
    PathBuf::from(name)
}

/// Remove what killed runs left of `path`: stale temporary files and staging folders; a
/// folder renamed away just before its swap is put back when `path` is missing.
pub fn clean_stale(path: &Path) {
    let files = stale(path, "tmp").into_iter().chain(stale(path, "spill"));
    for t in files.chain(stale(path, "new")) {
        let _ = std::fs::remove_dir_all(&t).or_else(|_| std::fs::remove_file(&t));
    }
    for old in stale(path, "old") {
        if !path.exists() && std::fs::rename(&old, path).is_ok() {
            continue;
        }
        let _ = std::fs::remove_dir_all(&old);
    }
}

/// Write `path` atomically: to a temporary file beside it, then renamed over it (stale
/// temporaries of killed runs are removed first).
pub fn write_atomic(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let io = |cause| Error::Write {
        path: path.to_path_buf(),
        cause,
    };
    clean_stale(path);
    let tmp = sibling(path, "tmp");
    let res = (|| {
        let file = Writeback::new(std::fs::File::create(&tmp)?);
        let mut w = std::io::BufWriter::new(file);
        f(&mut w)?;
        w.flush()?;
        w.into_inner()
            .map_err(|e| e.into_error())?
            .file
            .sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if res.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    res.map_err(io)
}

/// A file whose written pages are handed to the disk every few megabytes (Linux), so that the
/// closing `fsync` of a large output waits for the last few only instead of for all of it.
struct Writeback {
    file: std::fs::File,
    started: u64,
    pending: u64,
}

impl Writeback {
    /// Pages handed to the disk at a time.
    const STEP: u64 = 8 << 20;

    fn new(file: std::fs::File) -> Self {
        Writeback {
            file,
            started: 0,
            pending: 0,
        }
    }
}

impl Write for Writeback {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.file.write(buf)?;
        self.pending += n as u64;
        if self.pending >= Self::STEP {
            start_writeback(&self.file, self.started, self.pending);
            self.started += self.pending;
            self.pending = 0;
        }
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

/// Start writing `len` bytes of `file` from `offset` to the disk, without waiting; a hint
/// whose failure the closing `fsync` reports.
fn start_writeback(file: &std::fs::File, offset: u64, len: u64) {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        // SAFETY: sync_file_range only reads the descriptor and range; the file is open.
        unsafe {
            libc::sync_file_range(
                file.as_raw_fd(),
                offset as libc::off64_t,
                len as libc::off64_t,
                libc::SYNC_FILE_RANGE_WRITE,
            );
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (file, offset, len);
}

/// A folder being written whole: fill [`StagedDir::path`], then [`StagedDir::commit`] swaps it
/// in for the target. Dropped without a commit, the staging folder is removed and the target
/// stays as it was.
#[derive(Debug)]
pub struct StagedDir {
    target: PathBuf,
    staging: PathBuf,
    done: bool,
}

impl StagedDir {
    /// Start writing `target`, a folder of the files named in `owned`: leftovers of killed
    /// runs are cleaned up and an empty staging folder is made beside it. An existing target
    /// holding anything else (a user's files) is refused, since the commit replaces it whole.
    pub fn new(target: &Path, owned: &[&str]) -> Result<StagedDir> {
        let err = |cause| Error::Write {
            path: target.to_path_buf(),
            cause,
        };
        clean_stale(target);
        if target.is_file() {
            return Err(Error::input(
                target,
                "is a file, but an output folder is wanted: give a folder",
            ));
        }
        if target.exists() {
            let rd = std::fs::read_dir(target).map_err(err)?;
            let names: Vec<String> = rd
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect();
            if let Some(other) = names.iter().find(|n| !owned.contains(&n.as_str())) {
                return Err(Error::input(
                    target,
                    format!(
                        "holds `{other}`, which this command does not write, and an output folder \
                         is replaced whole: give a new or empty folder, or one of an earlier run"
                    ),
                ));
            }
        }
        let staging = sibling(target, "new");
        let _ = std::fs::remove_dir_all(&staging);
        std::fs::create_dir_all(&staging).map_err(err)?;
        Ok(StagedDir {
            target: target.to_path_buf(),
            staging,
            done: false,
        })
    }

    /// Where the files go until the commit.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// Put the written folder in place of the target: the old one renamed away, the new one
    /// renamed in, the old one removed. A kill between the two renames leaves the old folder
    /// beside the missing target, and the next run puts it back.
    pub fn commit(mut self) -> Result<()> {
        let err = |cause| Error::Write {
            path: self.target.clone(),
            cause,
        };
        let old = sibling(&self.target, "old");
        let had = self.target.exists();
        if had {
            std::fs::rename(&self.target, &old).map_err(err)?;
        }
        if let Err(e) = std::fs::rename(&self.staging, &self.target) {
            if had {
                let _ = std::fs::rename(&old, &self.target);
            }
            return Err(err(e));
        }
        self.done = true;
        if had {
            let _ = std::fs::remove_dir_all(&old);
        }
        Ok(())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.done {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_is_swapped_whole_and_leftovers_are_cleaned() {
        let base = testkit::scratch_dir("atomic");
        let out = base.join("out");
        std::fs::create_dir_all(&out).unwrap();
        std::fs::write(out.join("a"), "old a").unwrap();
        std::fs::write(out.join("b"), "old b").unwrap();
        // A killed run's leftovers (pid 4000000000 runs nowhere): a temporary, a staging
        // folder, and the old folder renamed away while `out` exists.
        std::fs::write(base.join(".out.4000000000.tmp"), "partial").unwrap();
        std::fs::create_dir_all(base.join(".out.4000000000.new")).unwrap();
        std::fs::create_dir_all(base.join(".out.4000000001.old")).unwrap();
        // A folder with files of others is refused.
        assert!(StagedDir::new(&out, &["a"]).is_err());
        // Not finished: the target stays as it was.
        let s = StagedDir::new(&out, &["a", "b"]).unwrap();
        std::fs::write(s.path().join("a"), "new a").unwrap();
        drop(s);
        assert_eq!(std::fs::read_to_string(out.join("a")).unwrap(), "old a");
        let s = StagedDir::new(&out, &["a", "b"]).unwrap();
        write_atomic(&s.path().join("a"), |w| w.write_all(b"new a")).unwrap();
        s.commit().unwrap();
        assert_eq!(std::fs::read_to_string(out.join("a")).unwrap(), "new a");
        assert!(!out.join("b").exists(), "nothing of the old set is left");
        let names: Vec<String> = std::fs::read_dir(&base)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["out"]);
        // Killed between the renames: the old folder comes back.
        std::fs::rename(&out, base.join(".out.4000000002.old")).unwrap();
        clean_stale(&out);
        assert_eq!(std::fs::read_to_string(out.join("a")).unwrap(), "new a");
        let _ = std::fs::remove_dir_all(&base);
    }
}
