//! Rerun flags of the commands that run the twin, after Rerun's own CLI conventions
//! (`--spawn`, `--connect [URL]`, `--save FILE.rrd`; cargo feature `viz`).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use powertwin::viz::{Sink, Viz};

/// Application id the viewer groups powertwin's recordings by.
const APP_ID: &str = "powertwin";

/// Where to send a Rerun recording of the run. Nothing listens on the network unless
/// `--spawn` is given, and the spawned viewer listens on 127.0.0.1 only.
#[derive(Debug, Args)]
pub struct VizArgs {
    /// Start a Rerun viewer (the `rerun` on PATH, listening on 127.0.0.1:9876 only, or the
    /// one already there) and stream the run to it.
    #[arg(long)]
    spawn: bool,
    /// Stream the run to a running Rerun viewer at URL [default:
    /// rerun+http://127.0.0.1:9876/proxy].
    #[arg(long, value_name = "URL", num_args = 0..=1)]
    connect: Option<Option<String>>,
    /// Save the run as a Rerun recording (view it with `rerun FILE.rrd`).
    #[arg(long, value_name = "FILE.rrd")]
    save: Option<PathBuf>,
}

impl VizArgs {
    /// Open a recording to the sinks asked for and to `always` (a file written in any case;
    /// not twice when `--save` names it too); `None` when there is none. Call it before the
    /// run, so that a viewer that cannot be started fails the command at once.
    pub fn open(&self, always: Option<&Path>) -> Result<Option<Viz>> {
        let mut sinks = Vec::new();
        if self.spawn {
            sinks.push(Sink::Spawn);
        }
        if let Some(url) = &self.connect {
            sinks.push(Sink::Connect(url.clone()));
        }
        let same = |a: &Path, b: &Path| {
            std::path::absolute(a)
                .ok()
                .is_some_and(|a| std::path::absolute(b).ok() == Some(a))
        };
        if let Some(path) = &self.save
            && !always.is_some_and(|a| same(a, path))
        {
            sinks.push(Sink::Save(path.clone()));
        }
        if let Some(path) = always {
            sinks.push(Sink::Save(path.to_path_buf()));
        }
        if sinks.is_empty() {
            return Ok(None);
        }
        Ok(Some(
            Viz::new(APP_ID, &sinks).context("opening the Rerun recording")?,
        ))
    }
}
