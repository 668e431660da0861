//! `tessera healthcheck`: GET a `/healthz` URL and exit 0 if it answers 200, 1 otherwise.
//!
//! Container images have no `curl` (the image is the binary alone), so Docker and Kubernetes
//! probes run this instead. It never retries: the orchestrator decides how often to ask.
use anyhow::{Context, bail};
use clap::Args;
use std::time::Duration;

#[derive(Args)]
pub struct HealthcheckArgs {
    /// The URL to check (a coordinator's `/healthz`).
    #[arg(long, env = "TESSERA_HEALTHCHECK_URL", default_value = "http://127.0.0.1:7878/healthz")]
    pub url: String,
    /// Seconds to wait for the whole answer (connection included).
    #[arg(long, default_value_t = 3.0)]
    pub timeout: f64,
}

pub fn run(a: HealthcheckArgs) -> anyhow::Result<()> {
    let timeout = timeout(a.timeout)?;
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    rt.block_on(async {
        let http = reqwest::Client::builder()
            .timeout(timeout)
            .build()
            .context("cannot build the HTTP client")?;
        let resp = http.get(&a.url).send().await.with_context(|| format!("GET {}", a.url))?;
        let status = resp.status();
        if !status.is_success() {
            bail!("GET {}: {status}", a.url);
        }
        println!("{}: {status}", a.url);
        Ok(())
    })
}

fn timeout(secs: f64) -> anyhow::Result<Duration> {
    Duration::try_from_secs_f64(secs)
        .ok()
        .filter(|d| !d.is_zero())
        .with_context(|| format!("--timeout {secs}: expected a number of seconds > 0"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timeouts_must_be_positive_and_finite() {
        assert_eq!(timeout(1.5).unwrap(), Duration::from_millis(1500));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(timeout(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn a_port_nobody_listens_on_is_unhealthy() {
        // Bind then drop: the port is free and refuses connections.
        let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let err =
            run(HealthcheckArgs { url: format!("http://127.0.0.1:{port}/healthz"), timeout: 1.0 })
                .unwrap_err();
        assert!(format!("{err:#}").contains("/healthz"), "{err:#}");
    }
}
