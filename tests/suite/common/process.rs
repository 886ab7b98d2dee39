//! The `sinscal` binary as an operator runs it: a child process started
//! with its command line, found by the address it prints, stopped by a
//! signal. Used by the tests that kill processes (`process_kill`,
//! `scale_out`).

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::Duration;

/// A running `sinscal` process.
pub struct Process {
    pub child: Child,
    /// `http://host:port`, as it printed.
    pub addr: String,
}

/// `sinscal` with `args`, to be given more and then [`Process::start`]ed.
pub fn sinscal(args: &[&str]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_sinscal"));
    cmd.args(args);
    cmd
}

impl Process {
    /// Starts `cmd` with its stderr appended to `log` and waits until it
    /// prints its address; returns it and the admin token if this start
    /// made the first one. The caller owns the child and waits for it
    /// ([`Process::sigkill`], [`Process::sigterm`]).
    #[allow(clippy::zombie_processes)]
    pub fn start(mut cmd: Command, log: &Path) -> (Process, Option<String>) {
        let stderr = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(log)
            .unwrap();
        let mut child = cmd
            .stdout(Stdio::piped())
            .stderr(stderr)
            .spawn()
            .expect("start sinscal");
        let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let mut token = None;
        loop {
            let line = lines
                .next()
                .unwrap_or_else(|| panic!("sinscal exited before listening; see {}", log.display()))
                .unwrap();
            if let Some(t) = line.strip_prefix("admin token (shown once, store it now): ") {
                token = Some(t.to_string());
            }
            if let Some((_, addr)) = line.split_once(" listening on ") {
                let addr = addr.to_string();
                return (Process { child, addr }, token);
            }
        }
    }

    /// The API's base URL on this process.
    pub fn api(&self) -> String {
        format!("{}/api/v1", self.addr)
    }

    /// Kills it (no chance to clean up) and reaps it.
    pub fn sigkill(&mut self) {
        self.child.kill().unwrap();
        self.child.wait().unwrap();
    }

    /// Asks it to stop (graceful shutdown) and waits for its exit.
    pub fn sigterm(mut self) -> ExitStatus {
        // SAFETY: signalling our own child by its pid.
        unsafe { libc::kill(self.child.id() as i32, libc::SIGTERM) };
        self.child.wait().unwrap()
    }
}

/// `GET url` with `token`, its JSON body.
pub async fn get_json(http: &reqwest::Client, token: &str, url: &str) -> serde_json::Value {
    http.get(url)
        .bearer_auth(token)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap()
}

/// Uploads a run (metadata and data bytes) for `serial` to the API at
/// `api` (`…/api/v1`); the answer as it came, or the transport's error
/// (a process killed mid-upload).
pub async fn upload_run(
    http: &reqwest::Client,
    api: &str,
    token: &str,
    serial: &str,
    meta: &[u8],
    data: Vec<u8>,
) -> reqwest::Result<reqwest::Response> {
    let form = reqwest::multipart::Form::new()
        .part("metadata", reqwest::multipart::Part::bytes(meta.to_vec()))
        .part("data", reqwest::multipart::Part::bytes(data));
    http.post(format!("{api}/units/{serial}/runs"))
        .bearer_auth(token)
        .multipart(form)
        .timeout(Duration::from_secs(60))
        .send()
        .await
}
