//! `Sink::Spawn` without a `rerun` executable on PATH is an error that says how to install
//! the viewer. Its own test binary: it empties PATH for the whole process.
#![cfg(feature = "viz")]

mod common;

use powertwin::Error;
use powertwin::viz::{Sink, Viz};

#[test]
fn spawn_without_a_viewer_says_how_to_install_one() {
    if common::rrd::viewer_listens() {
        return;
    }
    // SAFETY: this test binary has this one test and no other thread reads or writes the
    // environment yet (Rerun starts threads only once a recording exists).
    unsafe { std::env::set_var("PATH", "") };
    match Viz::new("powertwin_test", &[Sink::Spawn]) {
        Err(Error::Viz(msg)) => {
            assert!(msg.contains("pip install rerun-sdk==0.36.*"), "{msg}");
            assert!(
                msg.contains("cargo install rerun-cli --version 0.36.* --locked"),
                "{msg}"
            );
        }
        other => panic!("expected a missing-viewer error, got {other:?}"),
    }
}
