//! The views a calibration reads: images, folders of images and frames sampled from
//! videos, as `bendscope calibrate` and the Python package's `calibrate` take them.

use std::path::{Path, PathBuf};

use super::corners::{display_name, ViewSource};
use super::{CalibError, RejectedView};

/// Image file extensions read as calibration photos.
pub const IMAGE_EXTENSIONS: &[&str] = &["jpg", "jpeg", "png", "bmp", "tif", "tiff", "webp"];
/// Video file extensions sampled for calibration frames.
pub const VIDEO_EXTENSIONS: &[&str] = &["mp4", "mov", "m4v", "mkv", "avi", "webm"];

fn has_extension(path: &Path, exts: &[&str]) -> bool {
    path.extension()
        .map(|e| exts.contains(&e.to_string_lossy().to_ascii_lowercase().as_str()))
        .unwrap_or(false)
}

/// Turns the given paths (images, folders of images, videos) into views, `frames`
/// sampled evenly from each video; files in folders that are not images or
/// videos are listed as skipped.
pub fn collect_sources(
    paths: &[PathBuf],
    frames: u32,
) -> Result<(Vec<ViewSource>, Vec<RejectedView>), CalibError> {
    let mut sources = Vec::new();
    let mut skipped = Vec::new();
    for path in paths {
        if path.is_dir() {
            let mut entries: Vec<PathBuf> = std::fs::read_dir(path)
                .map_err(|source| CalibError::Io {
                    path: path.clone(),
                    source,
                })?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file())
                .collect();
            entries.sort();
            for p in entries {
                if has_extension(&p, IMAGE_EXTENSIONS) {
                    sources.push(ViewSource::Image(p));
                } else if has_extension(&p, VIDEO_EXTENSIONS) {
                    sources.extend(video_frames(&p, frames)?);
                } else {
                    skipped.push(RejectedView {
                        name: display_name(&p),
                        reason: "not an image or video file".to_string(),
                    });
                }
            }
        } else if path.is_file() {
            if has_extension(path, VIDEO_EXTENSIONS) {
                sources.extend(video_frames(path, frames)?);
            } else if has_extension(path, IMAGE_EXTENSIONS) {
                sources.push(ViewSource::Image(path.clone()));
            } else {
                return Err(CalibError::NotAnInput { path: path.clone() });
            }
        } else {
            return Err(CalibError::Io {
                path: path.clone(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file or folder"),
            });
        }
    }
    Ok((sources, skipped))
}

/// Frames sampled evenly from a video, as grey views.
fn video_frames(path: &Path, frames: u32) -> Result<Vec<ViewSource>, CalibError> {
    let sampled =
        crate::video::sample_evenly(path, frames as usize).map_err(|e| CalibError::Video {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    let stem = display_name(path);
    Ok(sampled
        .into_iter()
        .map(|f| ViewSource::Frame {
            name: format!("{stem}#frame{}", f.index),
            gray: image::DynamicImage::ImageRgb8(f.image).into_luma8(),
        })
        .collect())
}
