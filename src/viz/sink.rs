//! Where a recording goes, after Rerun's own CLI conventions (`--spawn`, `--connect [URL]`,
//! `--save PATH`).

use std::path::PathBuf;

use rerun::sink::{FileSink, GrpcSink, LogSink};

use super::viz_err;
use crate::error::{Error, Result};

/// How to install a viewer of the SDK's version; part of the error when none is found.
const INSTALL_HINT: &str = "install the viewer with `pip install rerun-sdk==0.36.*` or \
     `cargo install rerun-cli --version 0.36.* --locked`, or save to a file and open it later \
     with `rerun FILE.rrd`";

/// A destination of a [`super::Viz`] recording.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Sink {
    /// Start the `rerun` viewer found on `PATH`, listening on 127.0.0.1:9876 only (or use one
    /// already listening on that port), and stream to it.
    Spawn,
    /// Stream to a running viewer or server at a Rerun proxy URL
    /// (`rerun+http://HOST:PORT/proxy`); `None` is the local default
    /// `rerun+http://127.0.0.1:9876/proxy`.
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
                grpc(&format!("rerun+http://127.0.0.1:{}/proxy", info.port))
            }
            Sink::Connect(url) => grpc(url.as_deref().unwrap_or(rerun::DEFAULT_CONNECT_URL)),
            Sink::Save(path) => {
                Ok(Box::new(FileSink::new(path.clone()).map_err(|e| {
                    viz_err(&format!("cannot write {}", path.display()), e)
                })?))
            }
        }
    }
}

/// A gRPC sink to the proxy endpoint `url`.
fn grpc(url: &str) -> Result<Box<dyn LogSink>> {
    use rerun::external::re_uri::RedapUri;
    let not_proxy = || {
        Error::InvalidInput(format!(
            "'{url}' is not a Rerun proxy URL (expected rerun+http://HOST:PORT/proxy)"
        ))
    };
    match url.parse::<RedapUri>() {
        Ok(RedapUri::Proxy(uri)) => Ok(Box::new(GrpcSink::new(uri))),
        Ok(_) | Err(_) => Err(not_proxy()),
    }
}
