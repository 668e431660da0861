//! Headless Chromium driven over WebDriver (Debian's `chromium` + `chromium-driver`, via fantoccini).
use crate::cluster::Proc;
use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::{Value, json};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

pub const INSTALL: &str = "apt-get update && apt-get install -y chromium chromium-driver";

/// A browser session; chromedriver (and with it Chromium) is stopped on drop.
pub struct Browser {
    pub client: Client,
    pub downloads: PathBuf,
    _driver: Proc,
}

fn on_path(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path).map(|d| d.join(name)).find(|p| p.is_file())
}

/// The Chromium binary: Debian's real one behind its launcher script, or what is on PATH.
fn chromium() -> Option<PathBuf> {
    let debian = Path::new("/usr/lib/chromium/chromium");
    if debian.is_file() {
        return Some(debian.to_path_buf());
    }
    ["chromium", "chromium-browser", "google-chrome"].iter().find_map(|n| on_path(n))
}

/// chromedriver and Chromium. The browser tests are ignored unless asked for, so a machine
/// without them lists them as ignored; asked for where they are missing, the test fails and
/// says how to install them.
pub fn require() -> (PathBuf, PathBuf) {
    match (on_path("chromedriver"), chromium()) {
        (Some(d), Some(b)) => (d, b),
        _ => panic!("the dashboard test needs headless Chromium and chromedriver: `{INSTALL}`"),
    }
}

impl Browser {
    pub async fn start(driver: &Path, chromium: &Path, downloads: PathBuf) -> Browser {
        let mut child = Command::new(driver)
            .arg("--port=0")
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start chromedriver");
        let stdout = child.stdout.take().expect("piped");
        let proc = Proc(child);
        // Keep reading its log after the port line: a closed pipe would kill it on its next write.
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if let Some(p) = line.split("started successfully on port ").nth(1) {
                    let _ = tx.send(p.trim_end_matches('.').to_string());
                }
            }
        });
        let port = rx
            .recv_timeout(Duration::from_secs(20))
            .expect("chromedriver says which port it listens on");
        let caps = json!({
            "goog:chromeOptions": {
                "binary": chromium,
                "args": ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1280,1000", "--hide-scrollbars"],
                "prefs": {"download.default_directory": downloads, "download.prompt_for_download": false},
            }
        });
        let Value::Object(caps) = caps else { unreachable!() };
        let http = hyper_util::client::legacy::connect::HttpConnector::new();
        let client = ClientBuilder::new(http)
            .capabilities(caps)
            .connect(&format!("http://127.0.0.1:{port}"))
            .await
            .expect("WebDriver session");
        Browser { client, downloads, _driver: proc }
    }

    /// Runs `script` (a function body) in the page and returns its value.
    pub async fn js(&self, script: &str) -> Value {
        self.client
            .execute(script, vec![])
            .await
            .unwrap_or_else(|e| panic!("script failed: {e}\n{script}"))
    }

    pub async fn fill(&self, css: &str, text: &str) {
        let e = self.client.find(Locator::Css(css)).await.unwrap_or_else(|e| panic!("{css}: {e}"));
        e.clear().await.unwrap();
        e.send_keys(text).await.unwrap();
    }

    pub async fn click(&self, css: &str) {
        self.client
            .find(Locator::Css(css))
            .await
            .unwrap_or_else(|e| panic!("{css}: {e}"))
            .click()
            .await
            .unwrap();
    }

    /// Evaluates `script` every 50 ms until it returns something truthy; panics after `secs`.
    pub async fn until(&self, what: &str, secs: u64, script: &str) -> Value {
        let end = Instant::now() + Duration::from_secs(secs);
        loop {
            let v = self.js(script).await;
            if !(v.is_null() || v == json!(false) || v == json!("") || v == json!(0)) {
                return v;
            }
            assert!(
                Instant::now() < end,
                "timed out after {secs} s waiting for {what} (last: {v})"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    /// Waits for a finished download of `name` and returns its bytes.
    pub async fn downloaded(&self, name: &str, secs: u64) -> Vec<u8> {
        let path = self.downloads.join(name);
        let partial = self.downloads.join(format!("{name}.crdownload"));
        let end = Instant::now() + Duration::from_secs(secs);
        while !path.is_file() || partial.exists() {
            assert!(Instant::now() < end, "{} was not downloaded within {secs} s", path.display());
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        std::fs::read(&path).expect("read the download")
    }

    pub async fn screenshot(&self, path: &Path) {
        let png = self.client.screenshot().await.expect("screenshot");
        std::fs::write(path, png).expect("write the screenshot");
    }
}
