//! Small file helpers shared by every stage.
//!
//! Every result file bendscope writes goes through [`write_atomic`] (or
//! [`write_atomic_with`] for writers that stream): the bytes go to a temporary file in
//! the destination folder (tempfile's `NamedTempFile`), which is then renamed over the
//! destination, so a reader (or a crash) never sees a half-written file, and the
//! temporary file is removed when anything fails on the way. The temporary file is
//! created with mode 0666 less the process's umask (0644 under the usual 022), as a
//! plain `open` would make it, not tempfile's private 0600: results on a shared lab
//! machine are readable by colleagues and a web server.
//!
//! [`bounded_file_name`] keeps file names derived from user data (video names) within
//! what file systems accept; [`content_key`] is the stable fingerprint the caches use;
//! [`is_storage_full`] tells a full disk from other write errors; [`write_advice`] says
//! what a failed write means and what to do (free space, give another `-o`).
//! `non_finite` writes NaN and infinities to JSON so that they read back.

use std::fs;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use xxhash_rust::xxh3::Xxh3;

/// Name prefix of the temporary files [`write_atomic`] writes.
pub const TEMP_PREFIX: &str = ".bendscope-";
/// Name suffix of the temporary files [`write_atomic`] writes.
pub const TEMP_SUFFIX: &str = ".tmp";

/// Removes the temporary files [`write_atomic`] leaves in `dirs` (not their subfolders)
/// when a run is killed between writing and renaming; returns how many. Call it before
/// writing into an output folder, holding its lock ([`crate::lock`]): it would
/// remove the temporaries of another run writing there at the same time.
pub fn remove_stale_temporaries(dirs: &[PathBuf]) -> usize {
    let mut removed = 0;
    for dir in dirs {
        let Ok(rd) = fs::read_dir(dir) else { continue };
        for e in rd.flatten() {
            let name = e.file_name();
            let name = name.to_string_lossy();
            let is_file = e.file_type().map(|t| t.is_file()).unwrap_or(false);
            if is_file
                && name.starts_with(TEMP_PREFIX)
                && name.ends_with(TEMP_SUFFIX)
                && fs::remove_file(e.path()).is_ok()
            {
                removed += 1;
            }
        }
    }
    removed
}

/// Mode the result files are created with, before the umask.
pub const OUTPUT_MODE: u32 = 0o666;

/// Writes `bytes` to `path` atomically (temporary file in the same folder, then rename).
/// Creates the parent folder when missing. An error keeps the OS error's kind and its
/// text names `path` once (never the hidden temporary file) with [`write_advice`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_atomic_with(path, |f| f.write_all(bytes))
}

/// Like [`write_atomic`], with `write` filling the temporary file.
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&mut fs::File) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let fail = |e: std::io::Error| write_error(path, &parent, &e);
    fs::create_dir_all(&parent).map_err(fail)?;
    // Dropped on any error below: the temporary file is removed.
    let mut builder = tempfile::Builder::new();
    builder.prefix(TEMP_PREFIX).suffix(TEMP_SUFFIX);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // The mode goes to open(2), which applies the umask.
        builder.permissions(fs::Permissions::from_mode(OUTPUT_MODE));
    }
    let mut tmp = builder.tempfile_in(&parent).map_err(fail)?;
    write(tmp.as_file_mut()).map_err(fail)?;
    tmp.as_file().sync_all().map_err(fail)?;
    tmp.persist(path).map_err(|e| fail(e.error))?;
    Ok(())
}

/// Checks before the work that `path` can be written as a file: not a folder, its
/// folder made when missing and taking a write (a temporary file, removed at once), so a
/// read-only folder or a full disk is found before minutes of work. The error's text is
/// that of [`write_error`].
pub fn check_file_writable(path: &Path) -> std::io::Result<()> {
    if path.is_dir() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::IsADirectory,
            format!("{} is a folder: give -o a file name", path.display()),
        ));
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let fail = |e: std::io::Error| write_error(path, &parent, &e);
    fs::create_dir_all(&parent).map_err(fail)?;
    let mut probe = tempfile::Builder::new()
        .prefix(TEMP_PREFIX)
        .suffix(TEMP_SUFFIX)
        .tempfile_in(&parent)
        .map_err(fail)?;
    // One byte flushed: a full disk fails here (an empty file may still be made).
    probe.as_file_mut().write_all(b"x").map_err(fail)?;
    probe.as_file().sync_all().map_err(fail)?;
    Ok(())
}

/// The OS error number of "disk quota exceeded" (EDQUOT on Linux).
const EDQUOT: i32 = 122;
/// The OS error number of "read-only file system" (EROFS).
const EROFS: i32 = 30;

/// What a failed write into folder `dir` means for the user, and what to do: a full disk
/// ("no space left on the disk of DIR: free space and rerun"), a read-only or
/// unwritable folder ("give another -o"); other errors as the OS words them, without
/// the temporary file's path that tempfile adds.
pub fn write_advice(dir: &Path, e: &std::io::Error) -> String {
    // A file in the working folder: that folder by its full name.
    let here = (dir.as_os_str().is_empty() || dir == Path::new("."))
        .then(std::env::current_dir)
        .and_then(Result::ok);
    let dir = here.as_deref().unwrap_or(dir).display();
    let code = e.raw_os_error();
    if e.kind() == std::io::ErrorKind::StorageFull || code == Some(ENOSPC) {
        format!("no space left on the disk of {dir}: free space and rerun")
    } else if e.kind() == std::io::ErrorKind::QuotaExceeded || code == Some(EDQUOT) {
        format!("no space left on the disk of {dir} (disk quota exceeded): free space and rerun")
    } else if e.kind() == std::io::ErrorKind::ReadOnlyFilesystem || code == Some(EROFS) {
        format!("{dir} is read-only: give another -o")
    } else if e.kind() == std::io::ErrorKind::PermissionDenied {
        format!("{dir} is not writable (permission denied): give another -o")
    } else if let Some(code) = code {
        std::io::Error::from_raw_os_error(code).to_string()
    } else {
        // tempfile's errors end in "at path <the temporary file>".
        let text = e.to_string();
        match text.find(" at path ") {
            Some(at) => text[..at].to_string(),
            None => text,
        }
    }
}

/// `e`, met writing `path` into `dir`, as an error of the same kind whose text is
/// `path: ` and [`write_advice`].
pub fn write_error(path: &Path, dir: &Path, e: &std::io::Error) -> std::io::Error {
    std::io::Error::new(
        e.kind(),
        format!("{}: {}", path.display(), write_advice(dir, e)),
    )
}

/// `text` (an error about `path`) without a leading `path: `, for wrappers that name
/// `path` themselves.
pub fn without_path(path: &Path, text: &str) -> String {
    let prefix = format!("{}: ", path.display());
    text.strip_prefix(&prefix).unwrap_or(text).to_string()
}

/// `what` (an error about `path`) prefixed with `path` unless its text starts with it
/// already (the errors of [`write_atomic`] do): wrappers name a file once.
pub fn with_path(path: &Path, what: &dyn std::fmt::Display) -> String {
    let text = what.to_string();
    let name = path.display().to_string();
    if text.starts_with(&name) {
        text
    } else {
        format!("{name}: {text}")
    }
}

/// Longest file name (bytes) bendscope derives from user data; longer names are cut and
/// given a hash suffix (most file systems stop at 255 bytes, and `.png`, `.json` or a
/// temporary prefix must still fit).
pub const MAX_NAME_BYTES: usize = 120;

/// `name` + `ext` as a file name of at most [`MAX_NAME_BYTES`] bytes: unchanged when it
/// fits, else the first part of `name` (cut at a character boundary), `-` and 16 hex
/// digits of its hash, so distinct long names stay distinct. Path separators become `_`.
pub fn bounded_file_name(name: &str, ext: &str) -> String {
    let clean: String = name
        .chars()
        .map(|c| {
            if matches!(c, '/' | '\\' | '\0') {
                '_'
            } else {
                c
            }
        })
        .collect();
    if clean.len() + ext.len() <= MAX_NAME_BYTES {
        return format!("{clean}{ext}");
    }
    let keep = MAX_NAME_BYTES - ext.len() - 17;
    let mut cut = keep.min(clean.len());
    while !clean.is_char_boundary(cut) {
        cut -= 1;
    }
    let hash = xxhash_rust::xxh3::xxh3_64(name.as_bytes());
    format!("{}-{hash:016x}{ext}", &clean[..cut])
}

/// Size of the reads [`content_key`] hashes a file in (large reads keep the hash near
/// the disk's or page cache's throughput).
pub const KEY_READ_BYTES: usize = 4 << 20;

/// A stable fingerprint of a file's content (xxh3-128, the same across Rust releases
/// and machines): its size, modification time and every byte. The whole file is hashed:
/// a video damaged and restored in its middle (same size, same time, `cp -p`) must get
/// a new key. xxh3 streams at several GB/s, far above decoding (README: cache).
pub fn content_key(path: &Path) -> std::io::Result<u128> {
    let mut f = fs::File::open(path)?;
    let meta = f.metadata()?;
    let mut h = Xxh3::new();
    h.update(&meta.len().to_le_bytes());
    let mtime = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    h.update(&mtime.to_le_bytes());
    let mut buf = vec![0u8; KEY_READ_BYTES];
    loop {
        match f.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => h.update(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(h.digest128())
}

/// The OS error number of "no space left on device" (ENOSPC on Linux and macOS).
const ENOSPC: i32 = 28;

/// True when `e`, or an error it was caused by, says the device is full (an
/// [`std::io::Error`] of kind `StorageFull` or `QuotaExceeded`, OS error 28 or 122).
/// Errors that kept only their cause's text (a table's write error) are recognized by
/// it: `(os error 28)` or the words of [`write_advice`], `no space left on`.
pub fn is_storage_full(e: &(dyn std::error::Error + 'static)) -> bool {
    let mut next = Some(e);
    while let Some(err) = next {
        if let Some(io) = err.downcast_ref::<std::io::Error>() {
            if matches!(
                io.kind(),
                std::io::ErrorKind::StorageFull | std::io::ErrorKind::QuotaExceeded
            ) || matches!(io.raw_os_error(), Some(ENOSPC | EDQUOT))
            {
                return true;
            }
        }
        let text = err.to_string();
        if text.contains(&format!("(os error {ENOSPC})"))
            || text.to_ascii_lowercase().contains("no space left on")
        {
            return true;
        }
        next = err.source();
    }
    false
}

/// A stable hash of several parts (xxh3-128), each length-prefixed so that ("ab", "c")
/// and ("a", "bc") differ.
pub fn hash_parts<'a>(parts: impl IntoIterator<Item = &'a [u8]>) -> u128 {
    let mut h = Xxh3::new();
    for p in parts {
        h.update(&(p.len() as u64).to_le_bytes());
        h.update(p);
    }
    h.digest128()
}

/// Serde for an `f64` that may be NaN or infinite, as in the records of rejected frames:
/// JSON has no such numbers (serde_json writes them as `null`, which does not read back
/// as an `f64`, so a cache entry holding one would never be read). NaN is written as
/// `null`, infinities as the strings `"inf"` and `"-inf"`.
pub(crate) mod non_finite {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        match *v {
            v if v.is_finite() => s.serialize_f64(v),
            v if v.is_nan() => s.serialize_none(),
            v if v > 0.0 => s.serialize_str("inf"),
            _ => s.serialize_str("-inf"),
        }
    }

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Repr {
        Number(f64),
        Text(String),
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        match Option::<Repr>::deserialize(d)? {
            None => Ok(f64::NAN),
            Some(Repr::Number(v)) => Ok(v),
            Some(Repr::Text(t)) if t == "inf" => Ok(f64::INFINITY),
            Some(Repr::Text(t)) if t == "-inf" => Ok(f64::NEG_INFINITY),
            Some(Repr::Text(t)) => Err(serde::de::Error::custom(format!("`{t}` is not a number"))),
        }
    }
}

#[cfg(test)]
mod tests {
    /// The process's umask, from /proc/self/status (Linux).
    #[cfg(target_os = "linux")]
    fn umask() -> u32 {
        let status = std::fs::read_to_string("/proc/self/status").unwrap();
        let line = status.lines().find(|l| l.starts_with("Umask:")).unwrap();
        u32::from_str_radix(line.split_whitespace().nth(1).unwrap(), 8).unwrap()
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn results_are_created_with_the_umask_not_owner_only() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.csv");
        write_atomic(&p, b"x\n").unwrap();
        let mode = fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, OUTPUT_MODE & !umask(), "mode {mode:o}");
        // Under the usual umask 022: readable by everyone.
        if umask() == 0o022 {
            assert_eq!(mode, 0o644);
        }
    }

    use super::*;

    fn names(dir: &Path) -> Vec<std::ffi::OsString> {
        fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect()
    }

    #[test]
    fn writes_and_replaces_without_leaving_temporaries() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub").join("a.txt");
        write_atomic(&path, b"one").unwrap();
        write_atomic(&path, b"two").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"two");
        assert_eq!(names(path.parent().unwrap()).len(), 1);
    }

    #[test]
    fn a_failed_write_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        write_atomic(&path, b"old").unwrap();
        let e = write_atomic_with(&path, |f| {
            f.write_all(b"half")?;
            Err(std::io::Error::other("disk full"))
        });
        assert!(e.is_err());
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert_eq!(names(dir.path()).len(), 1, "{:?}", names(dir.path()));
    }

    #[test]
    fn stale_temporaries_are_removed_and_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("cache");
        fs::create_dir(&sub).unwrap();
        for p in [
            ".bendscope-a1B2c3.tmp",
            "keep.tmp",
            ".bendscope-notes",
            "a.json",
        ] {
            fs::write(sub.join(p), b"x").unwrap();
        }
        fs::write(dir.path().join(".bendscope-x.tmp"), b"x").unwrap();
        let n = remove_stale_temporaries(&[dir.path().to_path_buf(), sub.clone()]);
        assert_eq!(n, 2);
        let mut left = names(&sub);
        left.sort();
        assert_eq!(left, [".bendscope-notes", "a.json", "keep.tmp"]);
        assert_eq!(names(dir.path()), ["cache"]);
    }

    #[test]
    fn long_names_are_bounded_and_stay_distinct() {
        assert_eq!(
            bounded_file_name("GX010101.MP4", ".png"),
            "GX010101.MP4.png"
        );
        let a = "é".repeat(127) + "a.mp4";
        let b = "é".repeat(127) + "b.mp4";
        let (na, nb) = (
            bounded_file_name(&a, ".json"),
            bounded_file_name(&b, ".json"),
        );
        assert!(na.len() <= MAX_NAME_BYTES && nb.len() <= MAX_NAME_BYTES);
        assert_ne!(na, nb);
        assert!(na.ends_with(".json"));
        assert_eq!(bounded_file_name("a/b", ""), "a_b");
    }

    #[test]
    fn content_key_sees_a_changed_byte_in_the_middle_of_a_large_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.bin");
        let mut bytes = vec![7u8; 9 << 20];
        fs::write(&p, &bytes).unwrap();
        let t = fs::metadata(&p).unwrap().modified().unwrap();
        let k1 = content_key(&p).unwrap();
        // Beyond the first MiB and before the last one, across two reads.
        bytes[KEY_READ_BYTES] = 8;
        fs::write(&p, &bytes).unwrap();
        fs::File::options()
            .write(true)
            .open(&p)
            .unwrap()
            .set_modified(t)
            .unwrap();
        let k2 = content_key(&p).unwrap();
        assert_ne!(k2, k1);
        bytes[KEY_READ_BYTES] = 7;
        fs::write(&p, &bytes).unwrap();
        fs::File::options()
            .write(true)
            .open(&p)
            .unwrap()
            .set_modified(t)
            .unwrap();
        assert_eq!(content_key(&p).unwrap(), k1, "restored: the old key again");
    }

    #[test]
    fn storage_full_is_seen_through_causes_and_text() {
        let full = std::io::Error::from_raw_os_error(ENOSPC);
        assert!(is_storage_full(&full));
        assert!(is_storage_full(&std::io::Error::from(
            std::io::ErrorKind::StorageFull
        )));
        assert!(!is_storage_full(&std::io::Error::from(
            std::io::ErrorKind::PermissionDenied
        )));
        #[derive(Debug, thiserror::Error)]
        #[error("writing x: {0}")]
        struct Wrapped(String);
        assert!(is_storage_full(&Wrapped(full.to_string())));
        assert!(!is_storage_full(&Wrapped("denied".into())));
    }

    #[test]
    fn write_errors_name_the_file_once_and_say_what_to_do() {
        let dir = Path::new("out/plots");
        let file = dir.join("a.png");
        // (the error, the text expected, words it must not hold)
        let cases: [(std::io::Error, &str, &str); 6] = [
            (
                std::io::Error::from_raw_os_error(ENOSPC),
                "out/plots/a.png: no space left on the disk of out/plots: free space and rerun",
                "os error",
            ),
            (
                std::io::Error::from(std::io::ErrorKind::StorageFull),
                "out/plots/a.png: no space left on the disk of out/plots: free space and rerun",
                "os error",
            ),
            (
                std::io::Error::from_raw_os_error(EDQUOT),
                "out/plots/a.png: no space left on the disk of out/plots (disk quota exceeded): free space and rerun",
                "os error",
            ),
            (
                std::io::Error::from_raw_os_error(EROFS),
                "out/plots/a.png: out/plots is read-only: give another -o",
                "os error",
            ),
            (
                std::io::Error::from(std::io::ErrorKind::PermissionDenied),
                "out/plots/a.png: out/plots is not writable (permission denied): give another -o",
                "os error",
            ),
            (
                // tempfile's wording: the OS error and "at path" the temporary file.
                std::io::Error::new(
                    std::io::ErrorKind::IsADirectory,
                    std::io::Error::from_raw_os_error(21).to_string()
                        + " at path \"out/plots/.bendscope-XyZ123.tmp\"",
                ),
                "out/plots/a.png: Is a directory (os error 21)",
                ".bendscope-",
            ),
        ];
        for (e, want, refused) in cases {
            let got = write_error(&file, dir, &e);
            let text = got.to_string();
            assert_eq!(text, want);
            assert_eq!(got.kind(), e.kind(), "{text}");
            assert!(refused.is_empty() || !text.contains(refused), "{text}");
            assert_eq!(is_storage_full(&got), want.contains("no space"), "{text}");
        }
        let os = std::io::Error::from_raw_os_error(21);
        let text = write_advice(dir, &os);
        assert_eq!(text, "Is a directory (os error 21)");
        // A file in the working folder: the folder by its full name.
        let here = std::env::current_dir().unwrap();
        assert_eq!(
            write_advice(Path::new(""), &std::io::Error::from_raw_os_error(EROFS)),
            format!("{} is read-only: give another -o", here.display())
        );
        assert_eq!(
            with_path(&file, &text),
            "out/plots/a.png: Is a directory (os error 21)"
        );
        assert_eq!(
            without_path(&file, &write_error(&file, dir, &os).to_string()),
            "Is a directory (os error 21)"
        );
        assert_eq!(
            with_path(&file, &write_error(&file, dir, &os)),
            "out/plots/a.png: Is a directory (os error 21)"
        );
    }

    #[test]
    fn a_failed_write_names_the_destination_and_not_the_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        // The destination is a folder: the rename fails.
        let path = dir.path().join("a.html");
        fs::create_dir(&path).unwrap();
        fs::write(path.join("x"), b"x").unwrap();
        let e = write_atomic(&path, b"page").unwrap_err();
        let text = e.to_string();
        assert!(text.starts_with(&path.display().to_string()), "{text}");
        assert!(!text.contains(TEMP_PREFIX), "{text}");
        assert_eq!(names(dir.path()), ["a.html"], "no temporary left");
    }

    #[test]
    fn content_key_sees_a_replaced_file_of_the_same_size_and_time() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.bin");
        let mut bytes = vec![7u8; 3 << 20];
        fs::write(&p, &bytes).unwrap();
        let t = fs::metadata(&p).unwrap().modified().unwrap();
        let k1 = content_key(&p).unwrap();
        bytes[10] = 8;
        fs::write(&p, &bytes).unwrap();
        fs::File::options()
            .write(true)
            .open(&p)
            .unwrap()
            .set_modified(t)
            .unwrap();
        assert_ne!(content_key(&p).unwrap(), k1);
        assert_eq!(content_key(&p).unwrap(), content_key(&p).unwrap());
        assert_ne!(
            hash_parts([b"ab".as_slice(), b"c"]),
            hash_parts([b"a".as_slice(), b"bc"])
        );
    }
}
