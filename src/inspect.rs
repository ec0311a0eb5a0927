//! `inspect`: one frame with the session's marker thresholds, as a self-contained page
//! with sliders that recompute the mask in the browser (the interactive colour
//! thresholder of the published protocols, without MATLAB), the `[detect]` block to paste
//! into bendscope.toml, and a setting suggested from the frame.
//!
//! The page is plain HTML with inline JavaScript (no library, nothing fetched): the
//! frame as a PNG data URL, drawn into a canvas whose pixels are tested with the same
//! integer HSV band test as [`crate::detect::is_marker_colour`] (ported line by line),
//! so the mask in the browser is the mask `process` makes of the same pixels; the page
//! shows both counts (`data-rust-count` is computed here on the very pixels embedded).
//! A URL fragment such as `inspect.html#hue_min=35&hue_max=85` sets the sliders on load.
//!
//! The suggestion: every saturated, marker-sized blob of the frame (any hue, S >= 60,
//! V >= 40) is a candidate; blobs are grouped by their median hue, the group with the
//! most blobs (markers come in numbers, a tube or a label alone) gives the band: its
//! hues widened by [`SUGGEST_HUE_MARGIN`], S and V minima at [`SUGGEST_LEVEL_SHARE`] of
//! the group's 10th percentiles.

use std::path::{Path, PathBuf};

use base64::Engine as _;
use image::RgbImage;
use serde::Serialize;

use crate::detect::{
    detect_markers, is_marker_colour, mask_from_rgb, DetectSettings, HsvThresholds, HUE_MAX,
};
use crate::pipeline::source::{open_source, Next};
use crate::session::{is_photo, session_videos, SessionConfig, CONFIG};

/// Widest frame embedded in the page, px (larger frames are downscaled, so the browser
/// recomputes the mask at once on every slider move).
pub const PAGE_MAX_WIDTH: u32 = 960;
/// Hue margin added on each side of the suggested band (OpenCV units).
pub const SUGGEST_HUE_MARGIN: u8 = 4;
/// Share of the group's 10th-percentile S and V used as the suggested minima.
pub const SUGGEST_LEVEL_SHARE: f64 = 0.7;
/// Largest blob taken as marker-like when suggesting, px (at the page's size).
pub const SUGGEST_MAX_AREA_PX: u32 = 3000;
/// Blobs whose median hues lie within this distance (OpenCV units) form one group.
pub const SUGGEST_GROUP_HUE: i32 = 8;

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum InspectError {
    /// The input cannot be read.
    #[error("{path}: {why}")]
    Input {
        /// The session, video or image.
        path: PathBuf,
        /// What is wrong and what to do.
        why: String,
    },
}

/// One frame and what detection makes of it.
#[derive(Debug, Clone)]
pub struct Inspection {
    /// Where the frame came from (file and frame number).
    pub source: String,
    /// The frame at the page's size.
    pub frame: RgbImage,
    /// The settings in force (bendscope.toml or defaults).
    pub detect: DetectSettings,
    /// Pixels of the frame inside the band (the mask's area).
    pub mask_px: usize,
    /// Blob centroids and areas (page px).
    pub blobs: Vec<([f64; 2], u32)>,
    /// The band suggested from the frame, when marker-like coloured blobs were found.
    pub suggested: Option<Suggestion>,
}

/// A band read from the frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Suggestion {
    /// The band.
    pub band: HsvThresholds,
    /// Blobs in the group it was read from.
    pub blobs: usize,
}

/// The frame `frame` of `path` (a session folder: its first video or photo; a video; an
/// image) and the session settings that apply (`config`, else the bendscope.toml of the
/// session or of the file's folder, else the defaults).
pub fn load_frame(
    path: &Path,
    frame: u64,
    config: Option<&Path>,
) -> Result<(RgbImage, String, SessionConfig), InspectError> {
    let bad = |why: String| InspectError::Input {
        path: path.to_path_buf(),
        why,
    };
    if !path.exists() {
        return Err(bad("no such file or folder: check the path".into()));
    }
    let (media, folder) = if path.is_dir() && !is_photo_folder(path) {
        let first = session_videos(path)
            .into_iter()
            .map(|v| path.join(v))
            .chain(session_photos(path))
            .next();
        let first = match first {
            Some(f) => f,
            // An RGB-D session: its recording, or its first colour frame.
            None => match crate::rgbd::rgbd_frames(path).map_err(|e| bad(e.to_string()))? {
                Some(crate::rgbd::RgbdFrames::Bag(bag)) => bag,
                Some(crate::rgbd::RgbdFrames::PngFolders) => session_photos(&path.join("color"))
                    .into_iter()
                    .nth(usize::try_from(frame).unwrap_or(usize::MAX))
                    .ok_or_else(|| {
                        bad(format!(
                            "color/ has no frame {frame}: give a smaller --frame"
                        ))
                    })?,
                None => return Err(bad(
                    "no video, photo or RealSense recording in the folder: give a video or image"
                        .into(),
                )),
            },
        };
        (first, path.to_path_buf())
    } else {
        let parent = path.parent().map(Path::to_path_buf).unwrap_or_default();
        (path.to_path_buf(), parent)
    };
    let config_path = config
        .map(Path::to_path_buf)
        .or_else(|| Some(folder.join(CONFIG)).filter(|p| p.is_file()));
    let settings = match &config_path {
        Some(p) => SessionConfig::read(p).map_err(|e| bad(e.to_string()))?,
        None => SessionConfig::default(),
    };
    let name = media
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    if media
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("bag"))
    {
        let mut bag =
            crate::rgbd::bag::BagRecording::open(&media).map_err(|e| bad(e.to_string()))?;
        let n = bag.frames.len();
        let k = usize::try_from(frame)
            .ok()
            .filter(|k| *k < n)
            .ok_or_else(|| {
                bad(format!(
                    "{name} has {n} colour frames, no frame {frame}: give a smaller --frame"
                ))
            })?;
        let (rgb, _) = bag.read_frame(k).map_err(bad)?;
        return Ok((rgb, format!("{name}, frame {k}"), settings));
    }
    // The first colour frame of an RGB-D PNG session was picked above.
    let frame = if media.parent().is_some_and(|p| p.ends_with("color")) {
        0
    } else {
        frame
    };
    let mut source = open_source(&media, crate::video::FrameSelection::All, true).map_err(bad)?;
    loop {
        match source.next() {
            Next::Frame(f) if f.index >= frame => {
                return Ok((
                    f.pixels.to_rgb(),
                    format!("{name}, frame {}", f.index),
                    settings,
                ));
            }
            Next::Frame(_) | Next::Bad { .. } => {}
            Next::End => {
                return Err(bad(format!(
                    "{name} has no frame {frame}: give a smaller --frame"
                )))
            }
        }
    }
}

/// True for a folder of photos (a burst) rather than a session.
fn is_photo_folder(dir: &Path) -> bool {
    !dir.join(crate::session::MANIFEST).exists()
        && !dir.join(crate::session::PRESSURE_LOG).exists()
        && session_videos(dir).is_empty()
        && std::fs::read_dir(dir)
            .map(|rd| rd.flatten().any(|e| is_photo(&e.path())))
            .unwrap_or(false)
}

/// A session's photos (not its scale photo), sorted.
fn session_photos(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.flatten()
                .map(|e| e.path())
                .filter(|p| {
                    is_photo(p)
                        && !p
                            .file_stem()
                            .is_some_and(|s| s.to_string_lossy().eq_ignore_ascii_case("scale"))
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Detection on `frame` (downscaled to [`PAGE_MAX_WIDTH`]) with `detect`, and a suggested
/// band.
pub fn inspect_frame(frame: &RgbImage, source: String, detect: &DetectSettings) -> Inspection {
    let (w, h) = frame.dimensions();
    let k = w.div_ceil(PAGE_MAX_WIDTH).max(1);
    let frame = if k > 1 {
        image::imageops::resize(frame, w / k, h / k, image::imageops::FilterType::Triangle)
    } else {
        frame.clone()
    };
    // The page tests the plain band (no exposure adjustment), as the sliders set it.
    let plain = DetectSettings {
        auto_exposure: false,
        ..*detect
    };
    let mask = mask_from_rgb(&frame, &plain.hsv);
    let mask_px = mask.pixels().filter(|p| p[0] > 0).count();
    let blobs = detect_markers(&frame, &plain)
        .blobs
        .iter()
        .map(|b| ([b.centroid.x, b.centroid.y], b.area_px))
        .collect();
    let suggested = suggest_band(&frame, detect);
    Inspection {
        source,
        frame,
        detect: *detect,
        mask_px,
        blobs,
        suggested,
    }
}

/// OpenCV's 8-bit HSV of a pixel (H 0..180 rounded, S and V 0..255).
fn hsv(p: &image::Rgb<u8>) -> (i32, i32, i32) {
    let (r, g, b) = (p[0] as f64, p[1] as f64, p[2] as f64);
    let v = r.max(g).max(b);
    let d = v - r.min(g).min(b);
    let s = if v > 0.0 { 255.0 * d / v } else { 0.0 };
    let h = if d == 0.0 {
        0.0
    } else if v == r {
        30.0 * (g - b) / d
    } else if v == g {
        60.0 + 30.0 * (b - r) / d
    } else {
        120.0 + 30.0 * (r - g) / d
    };
    (
        h.rem_euclid(180.0).round() as i32 % 180,
        s.round() as i32,
        v as i32,
    )
}

/// The marker colour read from the frame (see the module doc), or `None` when no group of
/// at least 3 marker-like coloured blobs is found.
pub fn suggest_band(frame: &RgbImage, detect: &DetectSettings) -> Option<Suggestion> {
    let any_colour = DetectSettings {
        hsv: HsvThresholds {
            hue_min: 0,
            hue_max: HUE_MAX,
            s_min: 60,
            v_min: 40,
            v_max: 255,
        },
        max_area_px: SUGGEST_MAX_AREA_PX,
        auto_exposure: false,
        ..*detect
    };
    let mut groups: Vec<(i32, Vec<(i32, i32, i32)>, usize)> = Vec::new();
    for b in detect_markers(frame, &any_colour).blobs {
        let [x0, y0, x1, y1] = b.bbox;
        let px: Vec<(i32, i32, i32)> = (y0..=y1)
            .flat_map(|y| (x0..=x1).map(move |x| (x, y)))
            .map(|(x, y)| frame.get_pixel(x, y))
            .filter(|p| is_marker_colour(p[0], p[1], p[2], &any_colour.hsv))
            .map(hsv)
            .collect();
        if px.is_empty() {
            continue;
        }
        let mut hues: Vec<i32> = px.iter().map(|p| p.0).collect();
        hues.sort_unstable();
        let median = hues[hues.len() / 2];
        let near = |a: i32, b: i32| {
            let d = (a - b).rem_euclid(180);
            d.min(180 - d) <= SUGGEST_GROUP_HUE
        };
        match groups.iter_mut().find(|g| near(g.0, median)) {
            Some(g) => {
                g.1.extend(px);
                g.2 += 1;
            }
            None => groups.push((median, px, 1)),
        }
    }
    let (centre, px, n) = groups.into_iter().max_by_key(|g| g.2)?;
    if n < 3 {
        return None;
    }
    // Hues as offsets from the group's centre (wrapping), their 2nd and 98th percentiles.
    let mut off: Vec<i32> = px
        .iter()
        .map(|p| (p.0 - centre + 90).rem_euclid(180) - 90)
        .collect();
    off.sort_unstable();
    let pct = |v: &[i32], q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    let m = SUGGEST_HUE_MARGIN as i32;
    let lo = (centre + pct(&off, 0.02) - m).rem_euclid(180);
    let hi = (centre + pct(&off, 0.98) + m).rem_euclid(180);
    let mut s: Vec<i32> = px.iter().map(|p| p.1).collect();
    let mut v: Vec<i32> = px.iter().map(|p| p.2).collect();
    s.sort_unstable();
    v.sort_unstable();
    let level = |x: i32| ((x as f64 * SUGGEST_LEVEL_SHARE).round() as i32).clamp(0, 255) as u8;
    Some(Suggestion {
        band: HsvThresholds {
            hue_min: lo as u8,
            hue_max: hi as u8,
            s_min: level(pct(&s, 0.1)),
            v_min: level(pct(&v, 0.1)),
            v_max: 255,
        },
        blobs: n,
    })
}

/// The `[detect]` block of a band, to paste into bendscope.toml.
pub fn detect_block(t: &HsvThresholds) -> String {
    format!(
        "[detect]\nhue_min = {}\nhue_max = {}\ns_min = {}\nv_min = {}\nv_max = {}\n",
        t.hue_min, t.hue_max, t.s_min, t.v_min, t.v_max
    )
}

/// The page (self-contained HTML).
pub fn inspect_html(i: &Inspection) -> Result<String, InspectError> {
    let mut png = Vec::new();
    i.frame
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| InspectError::Input {
            path: PathBuf::from(&i.source),
            why: e.to_string(),
        })?;
    let b64 = base64::engine::general_purpose::STANDARD.encode(&png);
    let t = i.detect.hsv;
    let suggestion = match &i.suggested {
        Some(s) => format!(
            "<p>Suggested from {} marker-like blobs of one colour: <button id=\"use-suggested\" data-band=\"{},{},{},{},{}\">use it</button></p><pre id=\"suggested\">{}</pre>",
            s.blobs,
            s.band.hue_min,
            s.band.hue_max,
            s.band.s_min,
            s.band.v_min,
            s.band.v_max,
            crate::report::html::escape(&detect_block(&s.band))
        ),
        None => "<p id=\"suggested\">No group of 3 or more marker-like coloured blobs in this frame (dark markers: try <code>colour = \"dark\"</code>).</p>".to_string(),
    };
    let blobs: Vec<String> = i
        .blobs
        .iter()
        .map(|(c, a)| format!("[{:.2},{:.2},{a}]", c[0], c[1]))
        .collect();
    Ok(PAGE
        .replace("{SOURCE}", &crate::report::html::escape(&i.source))
        .replace("{W}", &i.frame.width().to_string())
        .replace("{H}", &i.frame.height().to_string())
        .replace("{PNG}", &b64)
        .replace("{RUST_COUNT}", &i.mask_px.to_string())
        .replace("{BLOBS}", &format!("[{}]", blobs.join(",")))
        .replace("{HUE_MIN}", &t.hue_min.to_string())
        .replace("{HUE_MAX}", &t.hue_max.to_string())
        .replace("{S_MIN}", &t.s_min.to_string())
        .replace("{V_MIN}", &t.v_min.to_string())
        .replace("{V_MAX}", &t.v_max.to_string())
        .replace("{SUGGESTION}", &suggestion))
}

/// The page template; `{NAME}` fields are filled by [`inspect_html`]. `bandTest` is
/// [`is_marker_colour`] in JavaScript.
const PAGE: &str = r##"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>bendscope inspect: {SOURCE}</title>
<style>
body { font-family: sans-serif; margin: 1em; }
.views { display: flex; gap: 1em; flex-wrap: wrap; }
canvas { border: 1px solid #999; max-width: 100%; }
label { display: inline-block; width: 6em; }
input[type=range] { width: 20em; vertical-align: middle; }
pre { background: #f4f4f4; padding: 0.5em; }
</style></head>
<body>
<h1>Marker colour: {SOURCE}</h1>
<p>Move the sliders until the mask (right) holds the markers and nothing else, then paste the block into bendscope.toml.
Hue is OpenCV's 0..180 (degrees / 2); hue_min above hue_max wraps through 0 (red).</p>
<div class="views"><canvas id="frame" width="{W}" height="{H}"></canvas><canvas id="mask" width="{W}" height="{H}"></canvas></div>
<div id="sliders">
<div><label for="hue_min">hue_min</label><input type="range" id="hue_min" min="0" max="180" value="{HUE_MIN}"> <output id="hue_min-value"></output></div>
<div><label for="hue_max">hue_max</label><input type="range" id="hue_max" min="0" max="180" value="{HUE_MAX}"> <output id="hue_max-value"></output></div>
<div><label for="s_min">s_min</label><input type="range" id="s_min" min="0" max="255" value="{S_MIN}"> <output id="s_min-value"></output></div>
<div><label for="v_min">v_min</label><input type="range" id="v_min" min="0" max="255" value="{V_MIN}"> <output id="v_min-value"></output></div>
<div><label for="v_max">v_max</label><input type="range" id="v_max" min="0" max="255" value="{V_MAX}"> <output id="v_max-value"></output></div>
</div>
<p>Mask: <span id="mask-count">?</span> px (bendscope's mask at the session's settings: <span id="rust-count" data-rust-count="{RUST_COUNT}">{RUST_COUNT}</span> px); <span id="blob-count"></span> blobs found by bendscope at the session's settings (circles).</p>
<pre id="block"></pre>
{SUGGESTION}
<img id="src" alt="frame" style="display:none" src="data:image/png;base64,{PNG}">
<script>
"use strict";
const keys = ["hue_min", "hue_max", "s_min", "v_min", "v_max"];
const blobs = {BLOBS};
let pixels = null;
function bandTest(r, g, b, t) {
  const v = Math.max(r, g, b);
  if (v < t.v_min || v > t.v_max) return false;
  const delta = v - Math.min(r, g, b);
  if (255 * delta < t.s_min * v) return false;
  if (t.hue_min === 0 && t.hue_max >= 180) return true;
  if (delta === 0) return false;
  let num;
  if (v === r) { num = 30 * (g - b); if (num < 0) num += 180 * delta; }
  else if (v === g) num = 60 * delta + 30 * (b - r);
  else num = 120 * delta + 30 * (r - g);
  const lo = t.hue_min * delta, hi = t.hue_max * delta;
  return t.hue_min <= t.hue_max ? (lo <= num && num <= hi) : (num >= lo || num <= hi);
}
function band() {
  const t = {};
  for (const k of keys) t[k] = parseInt(document.getElementById(k).value, 10);
  return t;
}
function update() {
  const t = band();
  for (const k of keys) document.getElementById(k + "-value").textContent = t[k];
  document.getElementById("block").textContent =
    "[detect]\n" + keys.map(k => k + " = " + t[k]).join("\n") + "\n";
  if (!pixels) return;
  const m = document.getElementById("mask").getContext("2d");
  const out = m.createImageData(pixels.width, pixels.height);
  const p = pixels.data;
  let count = 0;
  for (let i = 0; i < p.length; i += 4) {
    const hit = bandTest(p[i], p[i + 1], p[i + 2], t);
    if (hit) count++;
    out.data[i] = hit ? 255 : p[i] / 4;
    out.data[i + 1] = hit ? 0 : p[i + 1] / 4;
    out.data[i + 2] = hit ? 255 : p[i + 2] / 4;
    out.data[i + 3] = 255;
  }
  m.putImageData(out, 0, 0);
  document.getElementById("mask-count").textContent = count;
  document.body.dataset.maskCount = count;
}
function setBand(values) {
  keys.forEach((k, i) => { if (values[i] !== undefined && !isNaN(values[i])) document.getElementById(k).value = values[i]; });
  // As a user's slider move does.
  document.getElementById(keys[0]).dispatchEvent(new Event("input"));
}
for (const k of keys) document.getElementById(k).addEventListener("input", update);
const use = document.getElementById("use-suggested");
if (use) use.addEventListener("click", () => setBand(use.dataset.band.split(",").map(Number)));
document.getElementById("blob-count").textContent = blobs.length;
function start() {
  const img = document.getElementById("src");
  const f = document.getElementById("frame").getContext("2d");
  f.drawImage(img, 0, 0);
  pixels = f.getImageData(0, 0, img.width, img.height);
  f.strokeStyle = "#00e0ff";
  f.lineWidth = 1.5;
  for (const [x, y, a] of blobs) {
    f.beginPath();
    f.arc(x, y, Math.max(4, Math.sqrt(a / Math.PI) + 3), 0, 2 * Math.PI);
    f.stroke();
  }
  update();
  document.body.dataset.initialMaskCount = document.body.dataset.maskCount;
  // A fragment such as #hue_min=35&hue_max=85 moves the sliders.
  const given = new URLSearchParams(location.hash.slice(1));
  if (keys.some(k => given.has(k))) setBand(keys.map(k => given.has(k) ? parseInt(given.get(k), 10) : undefined));
  document.body.dataset.ready = "yes";
}
const img = document.getElementById("src");
if (img.complete) start(); else img.addEventListener("load", start);
</script>
</body></html>
"##;

#[cfg(test)]
mod tests {
    use super::*;

    /// A sheet with discs of one colour and one larger disc of another.
    fn frame(marker: [u8; 3], other: [u8; 3]) -> RgbImage {
        let discs: Vec<(f64, f64, f64, [u8; 3])> = (0..6)
            .map(|i| (20.0 + 25.0 * i as f64, 30.0, 4.0, marker))
            .chain([(80.0, 70.0, 9.0, other)])
            .collect();
        RgbImage::from_fn(180, 100, |x, y| {
            discs
                .iter()
                .find(|d| (x as f64 - d.0).hypot(y as f64 - d.1) <= d.2)
                .map(|d| image::Rgb(d.3))
                .unwrap_or(image::Rgb([228, 226, 220]))
        })
    }

    #[test]
    fn the_suggestion_is_the_colour_of_the_many_blobs() {
        let img = frame([40, 160, 70], [200, 30, 30]);
        let s = suggest_band(&img, &DetectSettings::default()).unwrap();
        assert_eq!(s.blobs, 6);
        let b = s.band;
        // Green (hue 67.5) inside, the red disc (hue 0) outside.
        assert!(
            b.hue_min < 67 && b.hue_max > 68 && b.hue_min < b.hue_max,
            "{b:?}"
        );
        assert!(is_marker_colour(40, 160, 70, &b));
        assert!(!is_marker_colour(200, 30, 30, &b));
        // Red markers beside one green thing: the red band, wrapping.
        let red = suggest_band(
            &frame([200, 30, 40], [40, 160, 70]),
            &DetectSettings::default(),
        )
        .unwrap()
        .band;
        assert!(is_marker_colour(200, 30, 40, &red) && !is_marker_colour(40, 160, 70, &red));
        assert!(red.hue_min > red.hue_max, "{red:?}");
        // No coloured markers: no suggestion.
        assert!(suggest_band(
            &frame([30, 30, 30], [30, 30, 30]),
            &DetectSettings::default()
        )
        .is_none());
    }

    #[test]
    fn the_page_embeds_the_frame_the_settings_and_the_mask_count() {
        let img = frame([200, 30, 40], [40, 160, 70]);
        let i = inspect_frame(&img, "x.png, frame 0".into(), &DetectSettings::default());
        assert_eq!(i.blobs.len(), 6);
        let disc_px = mask_from_rgb(&img, &HsvThresholds::default())
            .pixels()
            .filter(|p| p[0] > 0)
            .count();
        assert_eq!(i.mask_px, disc_px);
        let page = inspect_html(&i).unwrap();
        assert!(page.contains(&format!("data-rust-count=\"{disc_px}\"")));
        assert!(page.contains("id=\"hue_min\" min=\"0\" max=\"180\" value=\"170\""));
        assert!(page.contains("data:image/png;base64,"));
        assert!(!page.contains("{SUGGESTION}") && !page.contains("{PNG}"));
    }
}
