//! A farm in containers for the compose tests: the repository's docker-compose.yml, run as its
//! own compose project (unique name, torn down on drop even when a test fails), with the image
//! built from the static binary by deploy/build-image.sh.
use crate::harness::{repo_root, temp_dir};
use std::collections::HashMap;
use std::path::PathBuf;
use std::process::{Command, Output};
use std::sync::{Mutex, MutexGuard, OnceLock};
use std::time::{Duration, Instant};
use tessera_proto::WorkerInfo;
use tessera_server::client::Coordinator;

/// `docker compose` (v2) or `docker-compose` (v1), whichever answers; Err says why none can run.
fn compose_command() -> &'static Result<Vec<String>, String> {
    static FOUND: OnceLock<Result<Vec<String>, String>> = OnceLock::new();
    FOUND.get_or_init(|| {
        let info = Command::new("docker").args(["info", "--format", "{{.ServerVersion}}"]).output();
        match info {
            Ok(o) if o.status.success() => {}
            Ok(o) => {
                return Err(format!(
                    "no Docker engine reachable: {}",
                    String::from_utf8_lossy(&o.stderr).trim()
                ));
            }
            Err(e) => return Err(format!("no docker client: {e}")),
        }
        let candidates: [&[&str]; 2] = [&["docker", "compose"], &["docker-compose"]];
        for c in candidates {
            let ok = Command::new(c[0])
                .args(&c[1..])
                .arg("version")
                .output()
                .is_ok_and(|o| o.status.success());
            if ok {
                return Ok(c.iter().map(|s| s.to_string()).collect());
            }
        }
        Err("Docker runs but neither `docker compose` nor `docker-compose` is installed".into())
    })
}

/// The compose tests share two cores: one farm at a time. Panics, saying why, when no engine
/// runs here: the tests are ignored unless asked for, and asked for they must really run.
pub fn engine(test: &str) -> MutexGuard<'static, ()> {
    static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());
    if let Err(why) = compose_command() {
        panic!("{test}: {why} (the compose tests need a Docker engine and Compose)");
    }
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// The static binary deploy/build-image.sh puts in the image.
pub fn static_bin() -> PathBuf {
    let target = std::env::var("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|_| repo_root().join("target"));
    target.join("x86_64-unknown-linux-gnu/release/tessera")
}

/// Runs a command, panicking with its output if it fails.
pub fn run(cmd: &mut Command) -> Output {
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?} failed: {}\n{}",
        String::from_utf8_lossy(&out.stderr),
        String::from_utf8_lossy(&out.stdout)
    );
    out
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).trim().to_string()
}

pub struct ComposeFarm {
    project: String,
    image: String,
    env_file: PathBuf,
    lease_timeout_s: u32,
    client_token: String,
    pub url: String,
}

impl ComposeFarm {
    /// Builds the image, starts a coordinator and `workers` single-threaded workers, and waits
    /// until the coordinator answers from the host.
    pub fn up(name: &str, workers: usize, lease_timeout_s: u32) -> ComposeFarm {
        let now =
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
        let nonce = format!("{}-{}", std::process::id(), now.as_millis() % 1_000_000);
        let project = format!("tessera-e2e-{name}-{nonce}");
        let dir = temp_dir(&format!("compose-{name}"));
        let env_file = dir.join("tessera.env");
        let client_token = format!("client-{nonce}");
        std::fs::write(
            &env_file,
            format!("TESSERA_CLIENT_TOKEN={client_token}\nTESSERA_WORKER_TOKEN=worker-{nonce}\n"),
        )
        .unwrap();
        let image = format!("tessera-e2e:{project}");
        let mut farm = ComposeFarm {
            project,
            image,
            env_file,
            lease_timeout_s,
            client_token,
            url: String::new(),
        };
        let started = Instant::now();
        // The plain static binary .ci/run built, whatever PGO the shell exports (a profile-guided
        // build would add two builds to the test).
        run(Command::new(repo_root().join("deploy/build-image.sh"))
            .arg(&farm.image)
            .env("PGO", "0"));
        eprintln!("[{}] image built in {:.1}s", farm.project, started.elapsed().as_secs_f64());
        farm.compose(&["up", "-d", "--scale", &format!("worker={workers}")]);
        farm.find_coordinator();
        eprintln!(
            "[{}] up with {workers} workers in {:.1}s",
            farm.project,
            started.elapsed().as_secs_f64()
        );
        farm
    }

    /// Runs a compose command on this project; panics if it fails.
    pub fn compose(&self, args: &[&str]) -> Output {
        run(&mut self.compose_cmd(args))
    }

    fn compose_cmd(&self, args: &[&str]) -> Command {
        let Ok(base) = compose_command() else { unreachable!("checked by engine()") };
        let mut cmd = Command::new(&base[0]);
        cmd.args(&base[1..])
            .arg("-f")
            .arg(repo_root().join("docker-compose.yml"))
            .args(["-p", &self.project])
            .args(args)
            .env("TESSERA_IMAGE", &self.image)
            .env("TESSERA_ENV_FILE", &self.env_file)
            // An ephemeral host port on loopback: several projects can run at once.
            .env("TESSERA_PUBLISH", "127.0.0.1:")
            .env("TESSERA_LEASE_TIMEOUT", self.lease_timeout_s.to_string())
            .env("TESSERA_THREADS", "1");
        cmd
    }

    /// The coordinator's published address (it changes when the container restarts), once it
    /// answers /healthz from the host.
    pub fn find_coordinator(&mut self) {
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            let port = stdout(&self.compose(&["port", "coordinator", "7878"]));
            if !port.is_empty() && !port.ends_with(":0") {
                self.url = format!("http://{port}");
                let health = Command::new(static_bin())
                    .args([
                        "healthcheck",
                        "--timeout",
                        "1",
                        "--url",
                        &format!("{}/healthz", self.url),
                    ])
                    .output();
                if health.is_ok_and(|o| o.status.success()) {
                    return;
                }
            }
            assert!(Instant::now() < deadline, "the coordinator never answered at {port:?}");
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    pub fn client(&self) -> Coordinator {
        Coordinator::new(&self.url, Some(self.client_token.clone()))
    }

    /// Full ids of the running containers of a service.
    pub fn containers(&self, service: &str) -> Vec<String> {
        stdout(&self.compose(&["ps", "-q", service])).lines().map(str::to_string).collect()
    }

    /// The container whose host name (a worker's default name: the short container id) is `name`.
    pub fn container_of(&self, worker_name: &str) -> String {
        let all = self.containers("worker");
        all.iter()
            .find(|c| c.starts_with(worker_name))
            .unwrap_or_else(|| panic!("no container for worker {worker_name} in {all:?}"))
            .clone()
    }

    pub fn docker(&self, args: &[&str]) -> Output {
        run(Command::new("docker").args(args))
    }

    pub fn network(&self) -> String {
        format!("{}_default", self.project)
    }

    pub async fn workers(&self) -> Vec<WorkerInfo> {
        let body = self.client().bytes("/v1/workers").await.expect("GET /v1/workers");
        serde_json::from_slice(&body).expect("worker list")
    }

    /// The counters of /metrics, by name.
    pub async fn metrics(&self) -> HashMap<String, f64> {
        let text = String::from_utf8(self.client().bytes("/metrics").await.expect("GET /metrics"))
            .unwrap();
        text.lines()
            .filter(|l| !l.starts_with('#'))
            .filter_map(|l| l.rsplit_once(' '))
            .filter_map(|(k, v)| Some((k.to_string(), v.parse().ok()?)))
            .collect()
    }
}

impl Drop for ComposeFarm {
    fn drop(&mut self) {
        if std::thread::panicking() {
            // What the containers said is the best clue to a failure.
            if let Ok(logs) = self.compose_cmd(&["logs", "--no-color", "--tail", "30"]).output() {
                eprintln!(
                    "[{}] last logs:\n{}",
                    self.project,
                    String::from_utf8_lossy(&logs.stdout)
                );
            }
        }
        match self.compose_cmd(&["down", "-v", "--remove-orphans", "-t", "2"]).output() {
            Ok(o) if o.status.success() => {}
            other => {
                eprintln!("[{}] compose down failed, remove it by hand: {other:?}", self.project)
            }
        }
        let _ = Command::new("docker").args(["rmi", "-f", &self.image]).output();
        let _ = std::fs::remove_dir_all(self.env_file.parent().unwrap());
    }
}
