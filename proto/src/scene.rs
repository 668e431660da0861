//! Scene uploads.
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// `201 Created` answer to `POST /v1/scenes`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct SceneUploaded {
    /// sha256 of the uploaded bytes, lower-case hex.
    pub id: String,
    pub triangles: u64,
    pub effects: Vec<String>,
    pub cameras: Vec<String>,
}

/// One entry of `GET /v1/scenes`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct SceneListing {
    /// sha256 of the scene bytes.
    pub id: String,
    /// The bundled scene's name (usable in place of the id); null for uploads.
    pub name: Option<String>,
    pub triangles: u64,
    pub effects: Vec<String>,
    pub cameras: Vec<String>,
}
