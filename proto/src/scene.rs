//! Scene uploads.
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// A scene a job can use: the answer to `POST /v1/scenes` and `GET /v1/scenes/{id}`, and one
/// entry of `GET /v1/scenes`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SceneInfo {
    /// sha256 of the scene bytes, lower-case hex.
    pub id: String,
    /// The bundled scene's name (usable in place of the id); null for uploads.
    #[serde(default)]
    pub name: Option<String>,
    pub triangles: u64,
    pub effects: Vec<String>,
    pub cameras: Vec<String>,
    /// The glTF animations a job may play (`"animation"`: a name or an index into this list).
    #[serde(default)]
    pub animations: Vec<SceneAnimation>,
}

/// One glTF animation of a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SceneAnimation {
    pub name: Option<String>,
    /// Time of its last keyframe, in seconds.
    pub duration_s: f64,
}
