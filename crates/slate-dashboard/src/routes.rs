//! The HTTP routes: the page, the JSON snapshot, the WebSocket push and a health check.

use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::extract::State;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use tokio::sync::watch;

use crate::DashboardSource;
use crate::page;
use crate::snapshots::Snapshots;

/// How often a WebSocket client receives a snapshot.
pub(crate) const PUSH_EVERY: Duration = Duration::from_millis(250);

/// What every handler shares.
pub(crate) struct Shared {
    snapshots: Snapshots,
    stopped: watch::Receiver<bool>,
}

impl Shared {
    pub(crate) fn new(
        source: Arc<dyn DashboardSource>,
        stopped: watch::Receiver<bool>,
    ) -> Arc<Self> {
        Arc::new(Self {
            snapshots: Snapshots::new(source),
            stopped,
        })
    }
}

/// The dashboard's routes, all read-only (`GET`), behind the token if there is one.
pub(crate) fn router(shared: Arc<Shared>, token: Option<Arc<str>>) -> Router {
    Router::new()
        .route("/", get(page))
        .route("/api/snapshot", get(snapshot))
        .route("/ws", get(ws))
        .route("/healthz", get(healthz))
        .with_state(shared)
        .layer(axum::middleware::from_fn_with_state(
            token,
            crate::access::require,
        ))
}

/// Resolves once the server is told to stop (or its handle is gone).
pub(crate) async fn stopped(mut stopped: watch::Receiver<bool>) {
    let _ = stopped.wait_for(|stop| *stop).await;
}

async fn page() -> Response {
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        page::html(),
    )
        .into_response()
}

async fn snapshot(State(shared): State<Arc<Shared>>) -> Response {
    match shared.snapshots.get().await {
        Ok(json) => (
            [
                (header::CONTENT_TYPE, "application/json"),
                (header::CACHE_CONTROL, "no-store"),
            ],
            json.to_string(),
        )
            .into_response(),
        Err(_) => {
            tracing::error!("dashboard source panicked while taking a snapshot");
            (StatusCode::INTERNAL_SERVER_ERROR, "the source failed").into_response()
        }
    }
}

async fn healthz() -> &'static str {
    "ok"
}

async fn ws(State(shared): State<Arc<Shared>>, upgrade: WebSocketUpgrade) -> Response {
    upgrade.on_upgrade(move |socket| push(socket, shared))
}

/// Sends a snapshot every [`PUSH_EVERY`] until the client leaves or the server stops.
async fn push(mut socket: WebSocket, shared: Arc<Shared>) {
    tracing::debug!("dashboard client connected");
    let mut tick = tokio::time::interval(PUSH_EVERY);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let stop = stopped(shared.stopped.clone());
    tokio::pin!(stop);
    loop {
        tokio::select! {
            _ = tick.tick() => {
                let Ok(json) = shared.snapshots.get().await else {
                    tracing::error!("dashboard source panicked while taking a snapshot");
                    continue;
                };
                if socket.send(Message::Text(json.to_string().into())).await.is_err() {
                    break;
                }
            }
            incoming = socket.recv() => match incoming {
                None | Some(Err(_)) | Some(Ok(Message::Close(_))) => break,
                Some(Ok(_)) => {}
            },
            () = &mut stop => {
                let _ = socket.send(Message::Close(None)).await;
                break;
            }
        }
    }
    tracing::debug!("dashboard client disconnected");
}
