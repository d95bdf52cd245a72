//! Starting and stopping the server: a tokio runtime on its own thread, so synchronous
//! hosts (a node, the demo) can serve a dashboard without being async themselves.

use std::net::SocketAddr;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use tokio::sync::watch;

use crate::routes::{self, Shared};
use crate::{DashboardSource, ServeError};

/// How long open requests get to finish once `stop()` is called.
const GRACE: Duration = Duration::from_secs(2);
/// How long a source stuck in `snapshot()` may delay the end of `stop()`.
const BLOCKING_GRACE: Duration = Duration::from_secs(1);

/// Serves the dashboard for `source` on `addr` until the returned [`Dashboard`] is stopped
/// or dropped: open to anyone on a loopback address, behind a generated token on any
/// other ([`serve_with_token`]).
///
/// The address is bound before this returns, so a busy port is reported here
/// ([`ServeError::AddrInUse`]) and port 0 picks a free port ([`Dashboard::local_addr`]).
pub fn serve(addr: SocketAddr, source: Arc<dyn DashboardSource>) -> Result<Dashboard, ServeError> {
    serve_with_token(addr, source, None)
}

/// [`serve`], requiring `token` (`?token=TOKEN` or `Authorization: Bearer TOKEN`) on every
/// route but `/healthz`. Without one, a loopback address needs none and any other gets a
/// generated one, which [`Dashboard::url`] carries and the start is logged with.
pub fn serve_with_token(
    addr: SocketAddr,
    source: Arc<dyn DashboardSource>,
    token: Option<String>,
) -> Result<Dashboard, ServeError> {
    let token = crate::access::token_for(addr, token).map_err(ServeError::Start)?;
    let listener = std::net::TcpListener::bind(addr).map_err(|e| ServeError::bind(addr, e))?;
    listener.set_nonblocking(true).map_err(ServeError::Start)?;
    let local_addr = listener.local_addr().map_err(ServeError::Start)?;
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(ServeError::Start)?;
    let listener = {
        let _context = runtime.enter();
        tokio::net::TcpListener::from_std(listener).map_err(ServeError::Start)?
    };
    let (stop, stopped) = watch::channel(false);
    let app = routes::router(
        Shared::new(source, stopped.clone()),
        token.as_deref().map(Arc::from),
    );
    let thread = std::thread::Builder::new()
        .name("slate-dashboard".into())
        .spawn(move || run(runtime, listener, app, stopped))
        .map_err(ServeError::Start)?;
    let dashboard = Dashboard {
        local_addr,
        token,
        stop,
        thread: Some(thread),
    };
    tracing::info!(%local_addr, "dashboard serving on {}", dashboard.url());
    Ok(dashboard)
}

/// The server thread: serve until told to stop, give open requests [`GRACE`], then drop
/// everything still open.
fn run(
    runtime: tokio::runtime::Runtime,
    listener: tokio::net::TcpListener,
    app: axum::Router,
    stopped: watch::Receiver<bool>,
) {
    runtime.block_on(async move {
        let graceful =
            axum::serve(listener, app).with_graceful_shutdown(routes::stopped(stopped.clone()));
        tokio::select! {
            result = graceful => if let Err(error) = result {
                tracing::warn!(%error, "dashboard server failed");
            },
            () = async { routes::stopped(stopped).await; tokio::time::sleep(GRACE).await } => {
                tracing::debug!("dashboard grace period over; closing the remaining connections");
            }
        }
    });
    runtime.shutdown_timeout(BLOCKING_GRACE);
}

/// A running dashboard server. Stops when [`stop`](Self::stop)ped or dropped.
#[derive(Debug)]
pub struct Dashboard {
    local_addr: SocketAddr,
    /// What a client must show, if anything.
    token: Option<String>,
    stop: watch::Sender<bool>,
    thread: Option<JoinHandle<()>>,
}

impl Dashboard {
    /// The address actually bound (the real port when serving on port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }

    /// The page's URL, e.g. `http://127.0.0.1:8080/`, with `?token=TOKEN` when the
    /// dashboard requires one.
    pub fn url(&self) -> String {
        match &self.token {
            Some(token) => format!("http://{}/?token={token}", self.local_addr),
            None => format!("http://{}/", self.local_addr),
        }
    }

    /// The token clients must show, if any.
    pub fn token(&self) -> Option<&str> {
        self.token.as_deref()
    }

    /// Stops the server and waits for its thread; the port is free when this returns.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        let Some(thread) = self.thread.take() else {
            return;
        };
        self.stop.send_replace(true);
        if thread.join().is_err() {
            tracing::error!(local_addr = %self.local_addr, "dashboard server thread panicked");
        } else {
            tracing::info!(local_addr = %self.local_addr, "dashboard stopped");
        }
    }
}

impl Drop for Dashboard {
    fn drop(&mut self) {
        self.shutdown();
    }
}
