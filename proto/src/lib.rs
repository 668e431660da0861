//! Wire types shared by the coordinator and its workers.
//!
//! Everything that crosses the network lives here and only here, so that the tracer
//! (`tessera-worker::tracer`) stays free of serde and the HTTP layer.
