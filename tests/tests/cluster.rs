//! A farm of real processes on loopback: one coordinator (`tessera serve`) and workers
//! (`tessera work`), which tests can kill (SIGKILL), add and restart.
use crate::harness::{temp_dir, tessera_bin};
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use tessera_server::client::Coordinator;

/// A child process killed when dropped.
pub struct Proc(pub Child);

impl Proc {
    /// SIGKILL, as when a machine dies: no chance to clean up.
    pub fn kill9(mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }

    /// SIGTERM, then waits for the exit; returns whether it exited cleanly.
    pub fn terminate(mut self) -> bool {
        let _ = Command::new("kill").args(["-TERM", &self.0.id().to_string()]).status();
        self.0.wait().is_ok_and(|s| s.success())
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

pub struct Farm {
    pub url: String,
    pub data: PathBuf,
    pub coordinator: Option<Proc>,
    pub workers: Vec<Proc>,
    serve_args: Vec<String>,
    worker_token: Option<String>,
    tokens: Option<(String, String)>,
}

impl Farm {
    pub fn start(name: &str, workers: usize) -> Farm {
        Farm::start_with(name, workers, None, &[])
    }

    /// With `tokens` = (client, worker), the coordinator requires them and workers send theirs.
    /// `serve_args` are added to `tessera serve`.
    pub fn start_with(
        name: &str,
        workers: usize,
        tokens: Option<(&str, &str)>,
        serve_args: &[&str],
    ) -> Farm {
        let data = temp_dir(name);
        let _ = std::fs::remove_dir_all(&data);
        let mut farm = Farm {
            url: String::new(),
            data,
            coordinator: None,
            workers: Vec::new(),
            serve_args: serve_args.iter().map(|s| s.to_string()).collect(),
            worker_token: tokens.map(|t| t.1.to_string()),
            tokens: tokens.map(|(c, w)| (c.to_string(), w.to_string())),
        };
        farm.start_coordinator("127.0.0.1:0");
        for _ in 0..workers {
            farm.add_worker();
        }
        farm
    }

    fn start_coordinator(&mut self, listen: &str) {
        let mut cmd = Command::new(tessera_bin());
        cmd.args(["serve", "--listen", listen, "--data"]).arg(&self.data).args(&self.serve_args);
        if !self.serve_args.iter().any(|a| a == "--lease-timeout") {
            cmd.args(["--lease-timeout", "5"]);
        }
        if let Some((c, w)) = &self.tokens {
            cmd.env("TESSERA_CLIENT_TOKEN", c).env("TESSERA_WORKER_TOKEN", w);
        }
        let log = self.data.with_extension("coordinator.log");
        let stderr =
            std::fs::OpenOptions::new().create(true).append(true).open(&log).expect("log file");
        let mut child =
            cmd.stdout(Stdio::piped()).stderr(stderr).spawn().expect("start coordinator");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let Some(url) = line.trim().strip_prefix("listening on ") else {
            panic!(
                "the coordinator did not start: {}",
                std::fs::read_to_string(&log).unwrap_or_default()
            );
        };
        self.url = url.to_string();
        self.coordinator = Some(Proc(child));
    }

    /// Kills the coordinator with SIGKILL and starts a new one on the same address and data.
    pub fn crash_and_restart_coordinator(&mut self) {
        self.coordinator.take().expect("running").kill9();
        let addr = self.url.trim_start_matches("http://").to_string();
        self.start_coordinator(&addr);
    }

    pub fn add_worker(&mut self) {
        let mut cmd = Command::new(tessera_bin());
        if let Some(t) = &self.worker_token {
            cmd.env("TESSERA_WORKER_TOKEN", t);
        }
        let child = cmd
            .args(["work", "--threads", "1", "--coordinator", &self.url])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start worker");
        self.workers.push(Proc(child));
    }

    /// SIGKILLs worker `i` (its place in the list is taken by the last worker).
    pub fn kill_worker(&mut self, i: usize) {
        self.workers.swap_remove(i).kill9();
    }

    pub fn client(&self) -> Coordinator {
        Coordinator::new(&self.url, self.tokens.as_ref().map(|t| t.0.clone()))
    }
}
