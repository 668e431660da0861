//! Domain errors → HTTP status codes with RFC 9457 problem+json bodies.
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use tessera_proto::Problem;

#[derive(Debug)]
pub struct AppError {
    pub status: StatusCode,
    pub detail: String,
    pub field: Option<String>,
}

impl AppError {
    pub fn new(status: StatusCode, detail: impl Into<String>) -> AppError {
        AppError { status, detail: detail.into(), field: None }
    }

    /// 400 naming the request field at fault.
    pub fn field(field: &str, detail: impl Into<String>) -> AppError {
        AppError {
            status: StatusCode::BAD_REQUEST,
            detail: detail.into(),
            field: Some(field.to_string()),
        }
    }

    pub fn not_found(what: impl Into<String>) -> AppError {
        AppError::new(StatusCode::NOT_FOUND, what)
    }

    pub fn internal(e: impl std::fmt::Display) -> AppError {
        AppError::new(StatusCode::INTERNAL_SERVER_ERROR, e.to_string())
    }
}

impl IntoResponse for AppError {
    fn into_response(self) -> Response {
        let problem = Problem {
            kind: "about:blank".into(),
            title: self.status.canonical_reason().unwrap_or("Error").into(),
            status: self.status.as_u16(),
            detail: self.detail,
            field: self.field,
        };
        let body = serde_json::to_vec(&problem).expect("problem serializes");
        (self.status, [(header::CONTENT_TYPE, "application/problem+json")], body).into_response()
    }
}

/// JSON bodies whose rejections (bad syntax, wrong types, unknown fields) become problem+json.
pub struct Json<T>(pub T);

impl<T, S> axum::extract::FromRequest<S> for Json<T>
where
    T: serde::de::DeserializeOwned,
    S: Send + Sync,
{
    type Rejection = AppError;

    async fn from_request(req: axum::extract::Request, state: &S) -> Result<Self, Self::Rejection> {
        match axum::Json::<T>::from_request(req, state).await {
            Ok(axum::Json(v)) => Ok(Json(v)),
            Err(rejection) => {
                let status = match rejection.status() {
                    StatusCode::PAYLOAD_TOO_LARGE => StatusCode::PAYLOAD_TOO_LARGE,
                    StatusCode::UNSUPPORTED_MEDIA_TYPE => StatusCode::UNSUPPORTED_MEDIA_TYPE,
                    _ => StatusCode::BAD_REQUEST,
                };
                let detail = rejection.body_text();
                let field = field_in(&detail);
                Err(AppError { status, detail, field })
            }
        }
    }
}

/// The field serde complained about, from messages like "unknown field `foo`" or "width: invalid type".
fn field_in(detail: &str) -> Option<String> {
    if let Some(rest) = detail.split("field `").nth(1) {
        return rest.split('`').next().map(str::to_string);
    }
    let body = detail
        .split("target type: ")
        .nth(1)
        .or_else(|| detail.split("as JSON: ").nth(1))
        .unwrap_or(detail);
    let (path, _) = body.split_once(": ")?;
    // An array element ("background[0]") is its field's fault.
    let path = path.split('[').next().unwrap_or(path);
    (!path.contains(' ') && !path.is_empty()).then(|| path.to_string())
}
