//! Shared helpers of the CLI end-to-end tests: run the real `plumbline` binary and inspect its result.

#![allow(dead_code)]

use std::process::Command;

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
