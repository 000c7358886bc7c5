//! Shared helpers of the system tests: run the real `plumbline` binary and inspect its result.

pub mod services;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// A prepared invocation of the binary.
pub struct Invocation(Command);

/// The outcome of a run.
pub struct Run {
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
}

/// `plumbline ARGS…` with a clean environment for PLUMBLINE_* settings.
pub fn plumbline(args: &[&str]) -> Invocation {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_plumbline"));
    cmd.args(args);
    for (key, _) in std::env::vars() {
        if key.starts_with("PLUMBLINE_") {
            cmd.env_remove(key);
        }
    }
    Invocation(cmd)
}

impl Invocation {
    /// Add arguments.
    pub fn args<'a>(mut self, args: impl IntoIterator<Item = &'a str>) -> Self {
        self.0.args(args);
        self
    }

    /// Run to completion.
    pub fn run(mut self) -> Run {
        let out = self.0.output().expect("the plumbline binary runs");
        Run {
            code: out.status.code(),
            stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
            stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        }
    }
}

impl Run {
    /// Assert exit code 0.
    pub fn success(&self) {
        assert_eq!(self.code, Some(0), "stdout:\n{}\nstderr:\n{}", self.stdout, self.stderr);
    }

    /// Assert a specific non-zero exit code.
    pub fn failure_with(&self, code: i32) {
        assert_eq!(self.code, Some(code), "stdout:\n{}\nstderr:\n{}", self.stdout, self.stderr);
    }
}

/// Write a file into the temp dir and return its path as a string.
pub fn write(dir: &tempfile::TempDir, name: &str, content: &str) -> String {
    let path = dir.path().join(name);
    std::fs::write(&path, content).expect("write test file");
    path.to_str().expect("utf-8 temp path").to_owned()
}

/// A directory made once per test build and shared by every test process of the binary: nextest runs each
/// test in its own process, so they agree through the file system. The first to create the lock file calls
/// `make` on a private directory and renames it into place once `marker` exists in it; the others wait. The
/// directory lives under `CARGO_TARGET_TMPDIR/name`, keyed by the test binary's build time; older ones are
/// removed, so one at most stays on disk.
pub fn once_per_build(name: &str, marker: &str, make: impl FnOnce(&Path)) -> PathBuf {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::create_dir_all(&root).expect("create the shared test directory");
    let exe = std::env::current_exe().expect("the test binary's path");
    let built = std::fs::metadata(exe).and_then(|m| m.modified()).expect("the test binary's build time");
    let stamp = built.duration_since(std::time::UNIX_EPOCH).expect("a time after 1970").as_millis();
    let (done, lock) = (root.join(format!("camp-{stamp}")), root.join(format!("lock-{stamp}")));
    let waited = Instant::now();
    loop {
        if done.join(marker).exists() {
            return done;
        }
        let stale = std::fs::metadata(&lock)
            .and_then(|m| m.modified())
            .is_ok_and(|t| t.elapsed().is_ok_and(|e| e.as_secs() > 900));
        if stale {
            let _ = std::fs::remove_file(&lock);
        }
        if std::fs::OpenOptions::new().write(true).create_new(true).open(&lock).is_ok() {
            for entry in std::fs::read_dir(&root).expect("list the shared test directory").flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                if (name.starts_with("camp-") || name.starts_with("tmp-")) && entry.path() != done {
                    let _ = std::fs::remove_dir_all(entry.path());
                }
            }
            let out = root.join(format!("tmp-{}", std::process::id()));
            make(&out);
            assert!(out.join(marker).exists(), "{} was not made in {}", marker, out.display());
            std::fs::rename(&out, &done).expect("rename the made directory into place");
            let _ = std::fs::remove_file(&lock);
            return done;
        }
        assert!(waited.elapsed().as_secs() < 1200, "waited 20 min for another test process to make {name}");
        std::thread::sleep(Duration::from_millis(500));
    }
}

/// Copy the directory tree `src` to `dst`.
pub fn copy_dir(src: &Path, dst: &Path) {
    std::fs::create_dir_all(dst).expect("create the copy's directory");
    for entry in std::fs::read_dir(src).expect("read the directory to copy") {
        let entry = entry.expect("a directory entry");
        let to = dst.join(entry.file_name());
        if entry.file_type().expect("its file type").is_dir() {
            copy_dir(&entry.path(), &to);
        } else {
            std::fs::copy(entry.path(), to).expect("copy a file");
        }
    }
}
