//! Where a recording goes, after Rerun's own CLI conventions (`--spawn`, `--connect [URL]`,
//! `--save PATH`).

use std::net::{TcpStream, ToSocketAddrs};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use rerun::sink::{FileSink, GrpcSink, LogSink};

use super::viz_err;
use crate::error::{Error, Result};

/// How to install a viewer of the SDK's version; part of the error when none is found.
const INSTALL_HINT: &str = "install the viewer with `pip install rerun-sdk==0.36.*` or \
     `cargo install rerun-cli --version 0.36.* --locked`, or save to a file and open it later \
     with `rerun FILE.rrd`";

/// Longest wait for a viewer at a [`Sink::Connect`] URL to accept a connection, s.
const CONNECT_TIMEOUT_S: u64 = 2;

/// Longest wait for a spawned viewer to start listening, s.
const SPAWN_TIMEOUT_S: u64 = 20;

/// A destination of a [`super::Viz`] recording.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Sink {
    /// Start the `rerun` viewer found on `PATH`, listening on 127.0.0.1:9876 only (or use one
    /// already listening on that port), and stream to it.
    Spawn,
    /// Stream to a running viewer or server at a Rerun proxy URL
    /// (`rerun+http://HOST:PORT/proxy`); `None` is the local default
    /// `rerun+http://127.0.0.1:9876/proxy`. Opening fails when nothing accepts a connection
    /// there within 2 s (Rerun would otherwise block once its send queue is full).
    Connect(Option<String>),
    /// Write an `.rrd` file (created or truncated), to open later with `rerun FILE.rrd`.
    Save(PathBuf),
}

impl Sink {
    /// The Rerun log sink for this destination.
    pub(super) fn open(&self) -> Result<Box<dyn LogSink>> {
        match self {
            Sink::Spawn => {
                // The viewer's own default binds every interface; localhost is enough here.
                let opts = rerun::SpawnOptions {
                    extra_args: vec!["--bind".into(), "127.0.0.1".into()],
                    ..Default::default()
                };
                let info = rerun::spawn(&opts).map_err(|e| match e {
                    rerun::SpawnError::ExecutableNotFoundInPath { .. } => Error::Viz(format!(
                        "no Rerun viewer (`rerun`) found on PATH: {INSTALL_HINT}"
                    )),
                    other => viz_err("cannot start the Rerun viewer", other),
                })?;
                let url = format!("rerun+http://127.0.0.1:{}/proxy", info.port);
                grpc(&url, SPAWN_TIMEOUT_S).map_err(|e| match e {
                    Error::Viz(_) => Error::Viz(format!(
                        "the Rerun viewer started but did not listen at {url} within \
                         {SPAWN_TIMEOUT_S} s (no display?); save to a file instead and open it \
                         later with `rerun FILE.rrd`"
                    )),
                    other => other,
                })
            }
            Sink::Connect(url) => grpc(
                url.as_deref().unwrap_or(rerun::DEFAULT_CONNECT_URL),
                CONNECT_TIMEOUT_S,
            ),
            Sink::Save(path) => {
                Ok(Box::new(FileSink::new(path.clone()).map_err(|e| {
                    viz_err(&format!("cannot write {}", path.display()), e)
                })?))
            }
        }
    }
}

/// A gRPC sink to the proxy endpoint `url`, once something listens there (waiting at most
/// `timeout_s`, s); Rerun's sink would block the logging calls once its queue is full.
fn grpc(url: &str, timeout_s: u64) -> Result<Box<dyn LogSink>> {
    use rerun::external::re_uri::RedapUri;
    let uri = match url.parse::<RedapUri>() {
        Ok(RedapUri::Proxy(uri)) => uri,
        Ok(_) | Err(_) => {
            return Err(Error::InvalidInput(format!(
                "'{url}' is not a Rerun proxy URL (expected rerun+http://HOST:PORT/proxy)"
            )));
        }
    };
    let address = format!("{}:{}", uri.origin.format_host(), uri.origin.port);
    if !listens(&address, Duration::from_secs(timeout_s)) {
        return Err(Error::Viz(format!(
            "no Rerun viewer listens at {url}: start one with `rerun` ({INSTALL_HINT})"
        )));
    }
    Ok(Box::new(GrpcSink::new(uri)))
}

/// Whether something at `address` (`host:port`) accepts a TCP connection within `timeout`.
fn listens(address: &str, timeout: Duration) -> bool {
    let Ok(addrs) = address.to_socket_addrs() else {
        return false;
    };
    let addrs: Vec<_> = addrs.collect();
    let start = Instant::now();
    loop {
        let attempt = Duration::from_millis(500).min(timeout);
        if addrs
            .iter()
            .any(|a| TcpStream::connect_timeout(a, attempt).is_ok())
        {
            return true;
        }
        if start.elapsed() >= timeout {
            return false;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}
