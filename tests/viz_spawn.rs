//! `Sink::Spawn` without a `rerun` executable on PATH is an error that says how to install
//! the viewer. Its own test binary: it empties PATH for the whole process.
#![cfg(feature = "viz")]

use std::net::{Ipv4Addr, SocketAddr, TcpStream};
use std::time::Duration;

use powertwin::Error;
use powertwin::viz::{Sink, Viz};

#[test]
fn spawn_without_a_viewer_says_how_to_install_one() {
    // Rerun reuses a viewer already listening on the default port instead of spawning one;
    // then there is nothing to test here.
    let addr = SocketAddr::from((Ipv4Addr::LOCALHOST, 9876));
    if TcpStream::connect_timeout(&addr, Duration::from_millis(200)).is_ok() {
        eprintln!("a viewer listens on 127.0.0.1:9876; skipping the missing-viewer check");
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
