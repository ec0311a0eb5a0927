//! The per-video cache in `OUT/cache/`: a rerun skips a video whose result is current.
//!
//! Current means: the same key, and every derived output the entry names (its overlay)
//! still on disk. The key ([`ItemKey`]) hashes the bendscope version, the cache format,
//! the session's settings, calibration and scale, the video's pressure, and the content
//! of every file of the video ([`crate::io::content_key`]), so a replaced video, a new
//! calibration or another version redoes the work. Entries are written atomically, so a
//! run killed at any moment leaves either the old entry or the new one.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::io::{bounded_file_name, hash_parts, write_atomic};

use super::records::FrameRecord;

/// Version of the entry layout; bump when [`CacheEntry`] or what it means changes.
pub const CACHE_FORMAT: u32 = 4;

/// A cache key: 32 hex digits.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ItemKey(pub String);

impl ItemKey {
    /// The key of an item measured with `settings` (the session-wide fingerprint) from
    /// `files` (content keys of its files) at `pressure_kpa`.
    pub fn new(settings: u128, files: &[u128], pressure_kpa: f64) -> Self {
        let mut parts: Vec<Vec<u8>> = vec![
            env!("CARGO_PKG_VERSION").as_bytes().to_vec(),
            CACHE_FORMAT.to_le_bytes().to_vec(),
            settings.to_le_bytes().to_vec(),
            pressure_kpa.to_bits().to_le_bytes().to_vec(),
        ];
        parts.extend(files.iter().map(|k| k.to_le_bytes().to_vec()));
        Self(format!(
            "{:032x}",
            hash_parts(parts.iter().map(|p| p.as_slice()))
        ))
    }
}

/// What the cache keeps of a measured video: enough to rebuild its records.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CacheEntry {
    /// The key it was measured under.
    pub key: ItemKey,
    /// Every frame's record.
    pub frames: Vec<FrameRecord>,
    /// Problems seen while reading (corrupt packets, truncation, overlay not written).
    pub problems: Vec<String>,
    /// The clamped-end marker (px) of the last measured frame: where the next video's
    /// marker chain starts (an actuator curled past 180 degrees brings its tip nearer
    /// the clamp side than its clamped end).
    pub clamp_marker_px: Option<(f64, f64)>,
    /// Derived outputs, relative to OUT (the overlay): the entry is stale when one is
    /// missing, so a rerun repairs it.
    pub outputs: Vec<String>,
}

/// The cache folder of one output folder.
#[derive(Debug, Clone)]
pub struct Cache {
    out: PathBuf,
}

impl Cache {
    /// The cache of `out` (`out/cache/`).
    pub fn new(out: &Path) -> Self {
        Self {
            out: out.to_path_buf(),
        }
    }

    fn path(&self, item: &str) -> PathBuf {
        self.out
            .join("cache")
            .join(bounded_file_name(item, ".json"))
    }

    /// The current entry of `item` under `key`, if any: unreadable, stale or
    /// incomplete entries count as absent.
    pub fn get(&self, item: &str, key: &ItemKey) -> Option<CacheEntry> {
        let text = std::fs::read_to_string(self.path(item)).ok()?;
        let entry: CacheEntry = serde_json::from_str(&text).ok()?;
        let complete = entry.outputs.iter().all(|o| self.out.join(o).is_file());
        (entry.key == *key && complete).then_some(entry)
    }

    /// Stores `entry` for `item` (atomically).
    pub fn put(&self, item: &str, entry: &CacheEntry) -> std::io::Result<()> {
        let text = serde_json::to_string(entry).map_err(std::io::Error::other)?;
        write_atomic(&self.path(item), text.as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::super::records::FrameStatus;
    use super::*;

    #[test]
    fn an_entry_is_current_only_under_its_key_and_with_its_outputs() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::new(dir.path());
        let key = ItemKey::new(1, &[2, 3], 50.0);
        assert_ne!(key, ItemKey::new(1, &[2, 4], 50.0));
        assert_ne!(key, ItemKey::new(1, &[2, 3], 50.5));
        let entry = CacheEntry {
            key: key.clone(),
            frames: vec![],
            problems: vec![],
            clamp_marker_px: Some((1.0, 2.0)),
            outputs: vec!["overlays/a.png".into()],
        };
        cache.put("a.mp4", &entry).unwrap();
        assert!(cache.get("a.mp4", &key).is_none(), "overlay missing");
        write_atomic(&dir.path().join("overlays/a.png"), b"png").unwrap();
        assert_eq!(cache.get("a.mp4", &key), Some(entry));
        assert!(cache.get("a.mp4", &ItemKey::new(9, &[], 0.0)).is_none());
        std::fs::write(cache.path("a.mp4"), b"{garbage").unwrap();
        assert!(cache.get("a.mp4", &key).is_none());
    }

    #[test]
    fn cached_values_read_back_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::new(dir.path());
        let key = ItemKey::new(1, &[2], 50.0);
        // Values whose shortest decimal form a fast float parser may read 1 ULP off.
        let values: Vec<f64> = (1..2000)
            .map(|i| 1.0 / 3.0 * i as f64 + 1e-13 * i as f64)
            .collect();
        let frames = values
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                let mut f = FrameRecord::rejected("a.mp4", i as u64, v, v * 7.1, FrameStatus::Ok);
                f.radius_mm = v.sqrt();
                f
            })
            .collect();
        let entry = CacheEntry {
            key: key.clone(),
            frames,
            problems: vec![],
            clamp_marker_px: None,
            outputs: vec![],
        };
        cache.put("a.mp4", &entry).unwrap();
        let back = cache.get("a.mp4", &key).unwrap();
        for (a, b) in back.frames.iter().zip(&entry.frames) {
            assert_eq!(a.time_s.to_bits(), b.time_s.to_bits());
            assert_eq!(a.pressure_kpa.to_bits(), b.pressure_kpa.to_bits());
            assert_eq!(a.radius_mm.to_bits(), b.radius_mm.to_bits());
        }
    }
}
