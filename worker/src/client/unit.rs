//! One unit's life on this worker: its scene prepared and its rows queued on the pool (unless
//! the prefetch queued it), rendered under heartbeats, and how that ended.
use super::prepare::Prepared;
use super::queue::{self, Queued};
use super::retry::Stop;
use super::{SHUTDOWN_GRACE, Worker, convert, render_settings};
use std::sync::Mutex;
use std::time::{Duration, Instant};
use tessera_proto::Lease;
use tessera_render::tracer::{RowQueue, TileSums};
use tracing::{debug, error, info};

/// How a unit ended.
pub(super) enum Unit {
    Rendered {
        sums: TileSums,
        deadline: Instant,
        prepared: Prepared,
    },
    /// The lease was lost (409 on heartbeat, or its deadline passed): dropped.
    Canceled,
    /// Could not be worked (scene, parameters, renderer error): given back.
    Failed,
    /// Unfinished at the end of the shutdown grace: given back.
    Abandoned,
}

impl Worker {
    /// One unit under heartbeats: queued on the pool unless the prefetch did it (`queued`), then
    /// waited for. `scene_ready` is dropped once the unit is queued (or cannot be).
    pub(super) async fn run_unit(
        &self,
        lease: &Lease,
        queued: Option<Queued>,
        scene_ready: tokio::sync::oneshot::Sender<()>,
        heartbeat_every: Duration,
        stop: &Stop,
    ) -> Unit {
        let id = lease.lease_id.as_str();
        let deadline = Mutex::new(Instant::now() + Duration::from_millis(lease.deadline_ms));
        debug!(lease = id, job = %lease.job_id, tile = ?lease.tile, samples = ?lease.samples, queued = queued.is_some(), "leased a unit");
        let keep_alive = self.keep_alive(id, heartbeat_every, &deadline);
        tokio::pin!(keep_alive);

        // The frame's scene (from the cache, refitted, or built) and the unit queued behind it.
        let started = Instant::now();
        let mut unit = match queued {
            Some(q) => q,
            None => tokio::select! {
                r = self.queue_unit(lease) => match r {
                    Ok(q) => q,
                    Err(e) => {
                        error!(lease = id, job = %lease.job_id, "{e}; giving the lease back");
                        self.release(id).await;
                        return Unit::Failed;
                    }
                },
                why = &mut keep_alive => {
                    info!(lease = id, "lease lost while fetching its scene: {why}");
                    return Unit::Canceled;
                }
                () = stop.wait() => {
                    self.release(id).await;
                    return Unit::Abandoned;
                }
            },
        };

        drop(scene_ready);

        // The heartbeats and the shutdown request only set the unit's cancel flag, then wait
        // for the pool to let go (within a row), so the next unit finds it free.
        let grace = tokio::time::sleep(Duration::from_secs(365 * 24 * 3600));
        tokio::pin!(grace);
        let (mut lost, mut stopping, mut abandoned) = (None, false, false);
        let joined = loop {
            tokio::select! {
                joined = &mut unit.result => break joined,
                why = &mut keep_alive, if lost.is_none() => {
                    unit.cancel();
                    lost = Some(why);
                }
                () = stop.wait(), if !stopping => {
                    stopping = true;
                    grace.as_mut().reset(tokio::time::Instant::now() + SHUTDOWN_GRACE);
                    debug!(lease = id, "shutdown: the unit in hand gets {SHUTDOWN_GRACE:?} to finish");
                }
                () = &mut grace, if stopping && !abandoned => {
                    abandoned = true;
                    unit.cancel();
                }
            }
        };
        if let Some(why) = lost {
            info!(lease = id, job = %lease.job_id, "lease lost while rendering: {why}; unit dropped");
            return Unit::Canceled;
        }
        if abandoned {
            info!(
                lease = id,
                "unit unfinished at the end of the shutdown grace: giving the lease back"
            );
            self.release(id).await;
            return Unit::Abandoned;
        }
        let error = match joined {
            Ok(Ok(Some(sums))) => {
                debug!(lease = id, ms = started.elapsed().as_millis() as u64, "unit rendered");
                let deadline = *deadline.lock().expect("deadline lock");
                return Unit::Rendered { sums, deadline, prepared: unit.prepared };
            }
            Ok(Ok(None)) => "the render stopped without being canceled".to_owned(),
            Ok(Err(e)) => format!("the renderer failed: {e}"),
            Err(_) => "the render pool dropped the unit".to_owned(),
        };
        error!(lease = id, job = %lease.job_id, "{error}; giving the lease back");
        self.release(id).await;
        Unit::Failed
    }

    /// Prepares a unit (its settings, its frame's scene) and queues it on the render pool.
    pub(super) async fn queue_unit(&self, lease: &Lease) -> Result<Queued, String> {
        let settings = check_unit(lease).map_err(|e| format!("cannot work this unit: {e}"))?;
        let (scene, prepared) = self.frame_scene(lease).await?;
        let (tile, samples) = (convert::tile(lease.tile), lease.samples[0]..lease.samples[1]);
        let unit = RowQueue::new(scene, settings, tile, samples)
            .map_err(|e| format!("cannot render: {e}"))?;
        Ok(queue::queue(&self.pool, unit, prepared, self.busy_ns.clone()))
    }
}

/// The unit's render settings; frame n of an animation is rendered with its own seed
/// ([`frame_seed`](tessera_render::tracer::sampler::frame_seed), the job's seed for frame 0).
fn check_unit(lease: &Lease) -> Result<tessera_render::tracer::RenderSettings, String> {
    let mut settings = render_settings(&lease.params).map_err(|e| e.to_string())?;
    settings.seed = tessera_render::tracer::sampler::frame_seed(settings.seed, lease.frame);
    let [s0, s1] = lease.samples;
    if s1 <= s0 {
        return Err(format!("empty sample range [{s0}, {s1})"));
    }
    let t = lease.tile;
    if t.w == 0
        || t.h == 0
        || t.x0.checked_add(t.w).is_none_or(|x| x > settings.width)
        || t.y0.checked_add(t.h).is_none_or(|y| y > settings.height)
    {
        return Err(format!(
            "tile {t:?} is empty or exceeds the {}×{} image",
            settings.width, settings.height
        ));
    }
    Ok(settings)
}
