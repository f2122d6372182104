//! Reading an `.rrd` file back with Rerun's own decoder (entities, static data, rows per
//! timeline and blueprint chunks), and whether a viewer already listens locally.

use std::collections::BTreeMap;
use std::net::{Ipv4Addr, SocketAddr, TcpStream};
use std::path::Path;
use std::time::Duration;

use rerun::StoreKind;
use rerun::external::re_log_encoding::DecoderApp;
use rerun::log::{Chunk, LogMsg};

/// What one entity holds in the file: static chunks and rows per timeline.
#[derive(Debug, Default)]
pub struct EntityContent {
    pub has_static: bool,
    pub rows: BTreeMap<String, usize>,
}

/// What an `.rrd` file holds.
#[derive(Debug, Default)]
pub struct FileContent {
    pub entities: BTreeMap<String, EntityContent>,
    pub blueprint_chunks: usize,
}

impl FileContent {
    /// Rows of `entity` on `timeline` (0 if it has none there); panics naming the entities
    /// the file has when `entity` is missing.
    pub fn rows(&self, entity: &str, timeline: &str) -> usize {
        self.entity(entity).rows.get(timeline).copied().unwrap_or(0)
    }

    /// The entity; panics naming the entities the file has when it is missing.
    pub fn entity(&self, entity: &str) -> &EntityContent {
        self.entities
            .get(entity)
            .unwrap_or_else(|| panic!("entity {entity} missing; have {:?}", self.entity_names()))
    }

    /// Whether `entity` has static data (panics when it is missing).
    pub fn is_static(&self, entity: &str) -> bool {
        self.entity(entity).has_static
    }

    pub fn entity_names(&self) -> Vec<&String> {
        self.entities.keys().collect()
    }
}

/// Decode the file at `path` (entity paths without their leading slash).
pub fn read(path: &Path) -> FileContent {
    let file = std::fs::File::open(path).expect("rrd file exists");
    let decoder = DecoderApp::decode_eager(std::io::BufReader::new(file)).expect("valid rrd");
    let mut content = FileContent::default();
    for msg in decoder {
        let LogMsg::ArrowMsg(store_id, arrow) = msg.expect("message decodes") else {
            continue;
        };
        if store_id.kind() == StoreKind::Blueprint {
            content.blueprint_chunks += 1;
            continue;
        }
        let chunk = Chunk::from_arrow_msg(&arrow).expect("chunk decodes");
        let name = chunk.entity_path().to_string();
        let e = content
            .entities
            .entry(name.trim_start_matches('/').to_owned())
            .or_default();
        if chunk.is_static() {
            e.has_static = true;
        }
        for timeline in chunk.timelines().keys() {
            *e.rows.entry(timeline.to_string()).or_default() += chunk.num_rows();
        }
    }
    content
}

/// Whether a Rerun viewer listens on the default port 127.0.0.1:9876; spawning then reuses
/// it instead of looking for a `rerun` executable, so a missing-viewer test has nothing to
/// check (it says so on stderr).
pub fn viewer_listens() -> bool {
    let addr = SocketAddr::from((Ipv4Addr::LOCALHOST, 9876));
    let listens = TcpStream::connect_timeout(&addr, Duration::from_millis(200)).is_ok();
    if listens {
        eprintln!("a viewer listens on 127.0.0.1:9876; skipping the missing-viewer check");
    }
    listens
}
