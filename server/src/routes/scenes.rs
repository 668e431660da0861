//! `/v1/scenes`: upload (content-addressed) and download by hash.
use crate::error::AppError;
use crate::scenes::{PutError, SceneMeta};
use crate::state::AppState;
use axum::body::Bytes;
use axum::extract::{Path, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::IntoResponse;
use tessera_proto::{Problem, SceneInfo};

/// Upload a `.glb` (`model/gltf-binary`) or self-contained `.gltf` (`model/gltf+json`).
#[utoipa::path(post, path = "/v1/scenes", tag = "scenes", request_body(content = Vec<u8>, content_type = "model/gltf-binary"),
    responses((status = 201, body = SceneInfo), (status = 413, body = Problem), (status = 415, body = Problem), (status = 422, body = Problem), (status = 507, body = Problem)))]
pub async fn upload(
    State(st): State<AppState>,
    headers: HeaderMap,
    body: Bytes,
) -> Result<impl IntoResponse, AppError> {
    let ct = headers.get(header::CONTENT_TYPE).and_then(|v| v.to_str().ok()).unwrap_or("");
    let ct = ct.split(';').next().unwrap_or("").trim();
    if !matches!(
        ct,
        "model/gltf-binary"
            | "model/gltf+json"
            | "application/octet-stream"
            | "application/json"
            | ""
    ) {
        return Err(AppError::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            format!("content type {ct:?} is not model/gltf-binary or model/gltf+json"),
        ));
    }
    let st2 = st.clone();
    let meta = tokio::task::spawn_blocking(move || st2.scenes.put(&body))
        .await
        .map_err(AppError::internal)?
        .map_err(|e| match e {
            PutError::Invalid(why) => AppError::new(StatusCode::UNPROCESSABLE_ENTITY, why),
            PutError::Storage(e) => AppError::new(
                StatusCode::INSUFFICIENT_STORAGE,
                format!("the scene is valid but storing it failed: {e}"),
            ),
        })?;
    let location = format!("/v1/scenes/{}", meta.id);
    let name = st.scenes.bundled_name(&meta.id);
    Ok((StatusCode::CREATED, [(header::LOCATION, location)], axum::Json(described(name, meta))))
}

/// Every scene a job can use: the bundled ones (by name) and the uploaded ones (by id).
#[utoipa::path(get, path = "/v1/scenes", tag = "scenes", responses((status = 200, body = Vec<SceneInfo>)))]
pub async fn list(State(st): State<AppState>) -> axum::Json<Vec<SceneInfo>> {
    let all = st.scenes.list().into_iter();
    axum::Json(all.map(|(name, m)| described(name, m)).collect())
}

/// A stored scene's description (by id or bundled name).
#[utoipa::path(get, path = "/v1/scenes/{id}", tag = "scenes", params(("id" = String, Path)),
    responses((status = 200, body = SceneInfo), (status = 404, body = Problem)))]
pub async fn describe(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<axum::Json<SceneInfo>, AppError> {
    let m =
        st.scenes.resolve(&id).ok_or_else(|| AppError::not_found(format!("no scene {id:?}")))?;
    Ok(axum::Json(described(st.scenes.bundled_name(&m.id), m)))
}

/// The scene's bytes, for workers.
#[utoipa::path(get, path = "/v1/scenes/{id}/data", tag = "workers", params(("id" = String, Path)),
    responses((status = 200, content_type = "model/gltf-binary"), (status = 404, body = Problem)))]
pub async fn data(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<impl IntoResponse, AppError> {
    let bytes =
        st.scenes.bytes(&id).ok_or_else(|| AppError::not_found(format!("no scene {id:?}")))?;
    Ok(([(header::CONTENT_TYPE, "application/octet-stream")], bytes))
}

/// A stored scene as the API describes it.
fn described(name: Option<String>, m: SceneMeta) -> SceneInfo {
    SceneInfo {
        id: m.id,
        name,
        triangles: m.triangles,
        effects: m.effects,
        cameras: m.cameras,
        animations: m.animations,
    }
}
