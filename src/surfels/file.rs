//! The .gtsurf file format, version 1. Little-endian. A hierarchy is stored as the set it was
//! built from and its tile size, and rebuilt on load (`SurfelHierarchy::build` is deterministic),
//! so the file is as small as the .gtex and can never hold a hierarchy its set contradicts.
//!
//! ```text
//! header (32 bytes): magic b"GTSURF\r\n" | version u32 | tile u32 | payload length u64 |
//!                    CRC-32 of the tile (u32) and payload u32 | reserved u32
//! payload: the set as a complete .gtex file (gtex/file.rs, with its own header and checksum)
//! ```

use std::path::Path;
use std::sync::Arc;

use crate::error::{GeomtexError, Result};
use crate::gtex::file as gtex_file;
use crate::surfel_data::{check_tile, SurfelHierarchy};

pub const MAGIC: &[u8; 8] = b"GTSURF\r\n";
pub const VERSION: u32 = 1;
const HEADER: usize = 32;

/// CRC-32 of the tile size and the payload, so a changed tile is caught as corruption too.
fn checksum(tile: u32, payload: &[u8]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    h.update(&tile.to_le_bytes());
    h.update(payload);
    h.finalize()
}

pub fn encode(h: &SurfelHierarchy) -> Vec<u8> {
    let payload = gtex_file::encode(&h.source);
    let mut out = Vec::with_capacity(HEADER + payload.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&h.tile.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&checksum(h.tile, &payload).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&payload);
    out
}

/// The hierarchy a file's bytes hold, or what is wrong with them.
pub fn decode(bytes: &[u8]) -> std::result::Result<SurfelHierarchy, String> {
    if bytes.len() < HEADER || &bytes[..8] != MAGIC {
        return Err("not a surfel file (bad magic number or shorter than its header)".into());
    }
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    let version = word(8);
    if version != VERSION {
        return Err(format!(
            "surfel file format version {version}; this geomtex reads version {VERSION}"
        ));
    }
    let tile = word(12);
    let len = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
    let payload = &bytes[HEADER..];
    if payload.len() as u64 != len {
        return Err(format!(
            "truncated or padded: the header promises {len} payload bytes, the file has {}",
            payload.len()
        ));
    }
    if checksum(tile, payload) != word(24) {
        return Err("checksum mismatch: the file is corrupt".into());
    }
    let tile = check_tile(tile as i64).map_err(|e| e.to_string())?;
    let set = gtex_file::decode(payload).map_err(|e| format!("its set: {e}"))?;
    SurfelHierarchy::build(Arc::new(set), tile).map_err(|e| e.to_string())
}

impl SurfelHierarchy {
    /// Writes atomically (gtex::file::write_atomically).
    pub fn save(&self, path: &Path) -> Result<()> {
        gtex_file::write_atomically(path, &encode(self))
    }

    pub fn load(path: &Path) -> Result<SurfelHierarchy> {
        let bytes = std::fs::read(path)
            .map_err(|e| GeomtexError::io(format!("cannot read {}", path.display()), e))?;
        decode(&bytes).map_err(|e| GeomtexError::Format(format!("{}: {e}", path.display())))
    }
}
