//! The images of a job: its EXR and PNG preview, per frame for animations, and the whole
//! sequence as a zip.
//!
//! A frame whose job has ended (done, canceled or failed), or an animation's frame that is
//! complete while the job goes on, is served from its file (`crate::state::Shared::image_path`,
//! written once, so the bytes never change, after which the frame's sums are dropped);
//! otherwise the current merge is encoded on request.
//! `/v1/jobs/{id}/image.exr` and `preview.png` show a job's first frame.
use crate::error::AppError;
use crate::state::{AppState, JobImage};
use axum::extract::{Path, State};
use axum::http::header;
use axum::response::IntoResponse;
use std::io::Write;
use tessera_proto::Problem;

/// The job's OpenEXR image (its first frame): final once the job has ended, else the current merge.
#[utoipa::path(get, path = "/v1/jobs/{id}/image.exr", tag = "jobs", params(("id" = String, Path)),
    responses((status = 200, content_type = "image/x-exr"), (status = 404, body = Problem)))]
pub async fn image_exr(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<impl IntoResponse, AppError> {
    let bytes = frame_exr_bytes(&st, &id, 0).await?;
    Ok(([(header::CONTENT_TYPE, "image/x-exr")], bytes))
}

/// An sRGB PNG preview of the current merge (the first frame).
#[utoipa::path(get, path = "/v1/jobs/{id}/preview.png", tag = "jobs", params(("id" = String, Path)),
    responses((status = 200, content_type = "image/png"), (status = 404, body = Problem)))]
pub async fn preview_png(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<impl IntoResponse, AppError> {
    png(&st, &id, 0).await
}

/// One frame's OpenEXR image, by frame number: final once the job has ended, else the current merge.
#[utoipa::path(get, path = "/v1/jobs/{id}/frames/{n}/image.exr", tag = "jobs", params(("id" = String, Path), ("n" = u32, Path)),
    responses((status = 200, content_type = "image/x-exr"), (status = 404, body = Problem)))]
pub async fn frame_exr(
    State(st): State<AppState>,
    Path((id, n)): Path<(String, u32)>,
) -> Result<impl IntoResponse, AppError> {
    let index = frame_index(&st, &id, n)?;
    let bytes = frame_exr_bytes(&st, &id, index).await?;
    Ok(([(header::CONTENT_TYPE, "image/x-exr")], bytes))
}

/// One frame's sRGB PNG preview, by frame number.
#[utoipa::path(get, path = "/v1/jobs/{id}/frames/{n}/preview.png", tag = "jobs", params(("id" = String, Path), ("n" = u32, Path)),
    responses((status = 200, content_type = "image/png"), (status = 404, body = Problem)))]
pub async fn frame_png(
    State(st): State<AppState>,
    Path((id, n)): Path<(String, u32)>,
) -> Result<impl IntoResponse, AppError> {
    let index = frame_index(&st, &id, n)?;
    png(&st, &id, index).await
}

/// Every frame's EXR in one zip (stored, not recompressed: EXR is compressed already), named
/// `frame_0000.exr`, … by frame number.
#[utoipa::path(get, path = "/v1/jobs/{id}/frames.zip", tag = "jobs", params(("id" = String, Path)),
    responses((status = 200, content_type = "application/zip"), (status = 404, body = Problem)))]
pub async fn frames_zip(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<impl IntoResponse, AppError> {
    let numbers = {
        let s = st.scheduler.lock().expect("lock");
        let job = s.job(&id).ok_or_else(|| AppError::not_found(format!("no job {id:?}")))?;
        (0..job.frame_count()).map(|i| job.frame_number(i)).collect::<Vec<_>>()
    };
    let ended = finalize_if_ended(&st, &id).await?;
    let mut files = Vec::with_capacity(numbers.len());
    for (index, n) in numbers.into_iter().enumerate() {
        files.push((format!("frame_{n:04}.exr"), exr_bytes(&st, &id, index, ended).await?));
    }
    let zip = tokio::task::spawn_blocking(move || zip_stored(files))
        .await
        .map_err(AppError::internal)?
        .map_err(AppError::internal)?;
    let disposition = format!("attachment; filename=\"{id}-frames.zip\"");
    Ok((
        [
            (header::CONTENT_TYPE, "application/zip".to_string()),
            (header::CONTENT_DISPOSITION, disposition),
        ],
        zip,
    ))
}

fn zip_stored(files: Vec<(String, Vec<u8>)>) -> anyhow::Result<Vec<u8>> {
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Stored)
        .large_file(true);
    for (name, bytes) in files {
        zip.start_file(name, options)?;
        zip.write_all(&bytes)?;
    }
    Ok(zip.finish()?.into_inner())
}

/// The index of frame number `n` in the job's range.
fn frame_index(st: &AppState, id: &str, n: u32) -> Result<usize, AppError> {
    let s = st.scheduler.lock().expect("lock");
    let job = s.job(id).ok_or_else(|| AppError::not_found(format!("no job {id:?}")))?;
    (0..job.frame_count()).find(|&i| job.frame_number(i) == n).ok_or_else(|| {
        AppError::not_found(format!(
            "job {id:?} has no frame {n} (its frames are {:?})",
            job.cfg().frames
        ))
    })
}

async fn frame_exr_bytes(st: &AppState, id: &str, index: usize) -> Result<Vec<u8>, AppError> {
    let ended = finalize_if_ended(st, id).await?;
    exr_bytes(st, id, index, ended).await
}

/// True when the job has ended; its frame files are then written (now, if it ended a moment ago
/// and they are not yet).
async fn finalize_if_ended(st: &AppState, id: &str) -> Result<bool, AppError> {
    let ended = st.scheduler.lock().expect("lock").job(id).is_some_and(|j| j.state().is_final());
    if ended {
        let (st2, id2) = (st.clone(), id.to_string());
        tokio::task::spawn_blocking(move || st2.finalize(&id2))
            .await
            .map_err(AppError::internal)?;
    }
    Ok(ended)
}

/// Where a frame's pixels are: its written file, or the current merge.
enum Pixels {
    File(Vec<u8>),
    Merge(JobImage),
}

/// The file when the job has `ended` or the frame's sums were dropped (it completed while the
/// job goes on); else the current merge (also for an ended job whose file could not be
/// written, as long as its sums are kept).
async fn pixels(st: &AppState, id: &str, index: usize, ended: bool) -> Result<Pixels, AppError> {
    if (ended || released(st, id, index))
        && let Some(bytes) = image_file(st, id, index).await?
    {
        return Ok(Pixels::File(bytes));
    }
    match snapshot(st, id, index)? {
        Some(merge) => Ok(Pixels::Merge(merge)),
        // Released since the look above.
        None => image_file(st, id, index).await?.map(Pixels::File).ok_or_else(|| {
            AppError::not_found(format!(
                "frame {index} of job {id:?} has neither its sums nor its file"
            ))
        }),
    }
}

async fn exr_bytes(
    st: &AppState,
    id: &str,
    index: usize,
    ended: bool,
) -> Result<Vec<u8>, AppError> {
    match pixels(st, id, index, ended).await? {
        Pixels::File(bytes) => Ok(bytes),
        Pixels::Merge(merge) => tokio::task::spawn_blocking(move || merge.encode_exr())
            .await
            .map_err(AppError::internal)?
            .map_err(AppError::internal),
    }
}

/// The bytes of a frame's file; None when it is not there and the frame still has its sums to
/// encode instead; an error when neither is left.
async fn image_file(st: &AppState, id: &str, index: usize) -> Result<Option<Vec<u8>>, AppError> {
    let Some(path) = st.frame_image_path(id, index) else {
        return Err(AppError::not_found(format!("no job {id:?}")));
    };
    match tokio::fs::read(&path).await {
        Ok(bytes) => Ok(Some(bytes)),
        Err(e) if released(st, id, index) => Err(AppError::not_found(format!(
            "the image of job {id:?} was written to {} and cannot be read: {e}",
            path.display()
        ))),
        Err(_) => Ok(None),
    }
}

/// Whether frame index `index`'s sums were dropped: its file is all there is.
fn released(st: &AppState, id: &str, index: usize) -> bool {
    st.scheduler.lock().expect("lock").job(id).is_some_and(|j| j.frame_released(index))
}

/// A frame's PNG preview, from its file once written (the same pixels: the file holds the
/// merge's f32 means), else from the current merge.
async fn png(st: &AppState, id: &str, index: usize) -> Result<impl IntoResponse + use<>, AppError> {
    let ended = finalize_if_ended(st, id).await?;
    let png = match pixels(st, id, index, ended).await? {
        Pixels::File(bytes) => tokio::task::spawn_blocking(move || {
            crate::output::decode_exr(&bytes)
                .map(|(l, _)| crate::output::encode_png_preview(l.width, l.height, &l.rgb))
        })
        .await
        .map_err(AppError::internal)?
        .map_err(AppError::internal)?,
        Pixels::Merge(merge) => tokio::task::spawn_blocking(move || merge.encode_png())
            .await
            .map_err(AppError::internal)?,
    };
    Ok(([(header::CONTENT_TYPE, "image/png"), (header::CACHE_CONTROL, "no-store")], png))
}

/// The current merge of a frame, None when its sums were dropped (its file replaces them).
fn snapshot(st: &AppState, id: &str, index: usize) -> Result<Option<JobImage>, AppError> {
    let s = st.scheduler.lock().expect("lock");
    let job = s.job(id).ok_or_else(|| AppError::not_found(format!("no job {id:?}")))?;
    Ok((!job.frame_released(index)).then(|| JobImage::of(job, index, st.now())))
}
