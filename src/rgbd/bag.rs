//! RealSense `.bag` recordings (ROS1 bag v2.0, as the RealSense Viewer and `rs-record`
//! write them) read as an RGB-D session, message by message.
//!
//! # The layout, as librealsense names it
//!
//! Read in librealsense's `src/media/ros/ros_file_format.h` (`ros_topic`) and
//! `ros_reader.cpp` / `ros_writer.cpp` (file format version 3): every topic is
//! `/device_<d>/sensor_<s>/<Stream>_<i>/...` (`stream_full_prefix`), on a D4xx the
//! depth stream on sensor 0 and colour on sensor 1:
//!
//! ```text
//! .../Color_0/image/data          sensor_msgs/Image: rgb8 (or bgr8, rgba8, bgra8);
//!                                  header.stamp = the frame timestamp (ms / 1000),
//!                                  header.seq = the frame number
//! .../Depth_0/image/data          sensor_msgs/Image: mono16 (Z16) or 16UC1
//! .../<Stream>_0/info/camera_info sensor_msgs/CameraInfo: width, height, K, D,
//!                                  distortion_model (librealsense's model names)
//! .../<Stream>_0/tf/<group>       geometry_msgs/Transform, one per stream: the
//!                                  extrinsics from the group's reference ("pin")
//!                                  stream to this stream, p_stream = R p_ref + t,
//!                                  t in m (device::get_extrinsics fetches them
//!                                  from the pin stream to the stream;
//!                                  `convert(rs2_extrinsics, Transform)` stores R as
//!                                  a quaternion)
//! /device_<d>/sensor_<s>/option/Depth Units/value
//!                                  std_msgs/Float32: m per depth unit
//!                                  (`option_value_topic`; 0.001 when absent)
//! ```
//!
//! Depth to colour is therefore `T_color ∘ T_depth⁻¹` (on a D4xx depth is the pin
//! stream and its own transform is the identity). Frames are timed by the colour
//! images' header stamps: time 0 is the first colour frame's stamp (the bag's record
//! times are when the SDK wrote the message, not when the camera took the frame).
//! Each colour frame takes the depth frame of the nearest stamp, and has none when
//! that one is more than [`MAX_DEPTH_GAP_FRAMES`] colour frame periods away.
//!
//! # Reading
//!
//! The `rosbag` crate maps the file and decompresses one chunk (none, lz4 or bz2) at a
//! time. Opening reads the index (connections and chunk positions), then every chunk
//! once for the small messages (camera infos, transforms, depth units) and the image
//! headers only; frames are read later by chunk position, at most [`CHUNKS_CACHED`]
//! decompressed chunks held, so a recording is never in memory whole. A bag whose index
//! lies past its end (cut off while recording or copying) is refused before the crate
//! slices the map. The messages are decoded by hand ([`super::rosmsg`]).

use std::collections::{BTreeMap, VecDeque};
use std::io::Read;
use std::path::{Path, PathBuf};

use rosbag::{ChunkRecord, IndexRecord, MessageRecord, RosBag};

use super::align::{DepthAligner, StreamCamera};
use super::rosmsg::{
    camera_info_from_bytes, float32_from_bytes, image_from_bytes, image_header_from_bytes,
    transform_from_bytes, CameraInfoMsg, RigidTransform,
};
use super::DepthImage;
use super::{RgbdError, RgbdIntrinsics};

/// Colour stream name in librealsense's topics.
pub const COLOR_STREAM: &str = "Color_0";
/// Depth stream name in librealsense's topics.
pub const DEPTH_STREAM: &str = "Depth_0";
/// Topic tail of a stream's frames.
pub const IMAGE_DATA: &str = "image/data";
/// Topic tail of a stream's intrinsics.
pub const CAMERA_INFO: &str = "info/camera_info";
/// Topic tail of the depth unit option (under the depth stream's sensor).
pub const DEPTH_UNITS: &str = "option/Depth Units/value";
/// Depth unit when the bag does not record one, m (librealsense's default).
pub const DEFAULT_DEPTH_UNIT_M: f64 = 0.001;
/// Decompressed chunks kept while reading frames (a colour frame and its depth frame
/// are usually in the same or neighbouring chunks).
pub const CHUNKS_CACHED: usize = 4;
/// Largest stamp difference between a colour frame and its depth frame, in colour
/// frame periods (two free-running streams of one rate are at most half a period
/// apart; a dropped depth frame makes it one).
pub const MAX_DEPTH_GAP_FRAMES: f64 = 1.0;
/// Bytes read to find the bag header record (rosbag pads it to 4 KiB).
const HEADER_BYTES: u64 = 64 * 1024;
/// The version line a ROS1 bag v2.0 starts with.
const BAG_MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// Where a message is: the chunk's file position and its place among the chunk's
/// message records.
#[derive(Debug, Clone, Copy, PartialEq)]
struct MessageRef {
    chunk_pos: u64,
    nth: u32,
    stamp_ns: u64,
}

/// One colour frame of a recording and the depth frame matched to it.
#[derive(Debug, Clone, PartialEq)]
pub struct BagFrame {
    /// Place in time order, from 0.
    pub index: u64,
    /// Time, s, from the first colour frame's header stamp.
    pub time_s: f64,
    color: MessageRef,
    depth: Option<MessageRef>,
    /// Stamp difference to the nearest depth frame, s.
    pub depth_gap_s: f64,
}

/// A recording opened: cameras, extrinsics, depth unit and the frame list.
pub struct BagRecording {
    path: PathBuf,
    bag: RosBag,
    /// The colour camera, as the measuring code takes it (fps from the stamps).
    pub intrinsics: RgbdIntrinsics,
    /// The colour camera.
    pub color_camera: StreamCamera,
    /// The depth camera.
    pub depth_camera: StreamCamera,
    /// Depth camera frame -> colour camera frame.
    pub depth_to_color: RigidTransform,
    /// Metres per depth unit.
    pub depth_unit_m: f64,
    /// Colour frames in time order.
    pub frames: Vec<BagFrame>,
    /// How the frames were timed and matched, for the log.
    pub timing: String,
    /// What was assumed (no depth unit, no extrinsics), for the log.
    pub notes: Vec<String>,
    aligner: DepthAligner,
    cache: VecDeque<(u64, Vec<Vec<u8>>)>,
}

/// What a connection carries.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    ColorImage,
    DepthImage,
    ColorInfo,
    DepthInfo,
    ColorTf(u32),
    DepthTf(u32),
    DepthUnits,
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

/// Checks the bag header record: the version line, and an index that starts inside
/// the file (a bag cut off while recording or copying ends before it; one never closed
/// has index_pos 0).
fn check_header(path: &Path) -> Result<(), String> {
    let mut f = std::fs::File::open(path).map_err(|e| format!("cannot open ({e})"))?;
    let len = f
        .metadata()
        .map_err(|e| format!("cannot read ({e})"))?
        .len();
    let mut head = Vec::new();
    f.by_ref()
        .take(HEADER_BYTES)
        .read_to_end(&mut head)
        .map_err(|e| format!("cannot read ({e})"))?;
    if !head.starts_with(BAG_MAGIC) {
        return Err(
            "not a ROS1 bag v2.0 (no `#ROSBAG V2.0` line): record with the RealSense Viewer or rs-record (ROS2 bags are not read)".into(),
        );
    }
    let u32_at = |at: usize| -> Option<u32> {
        head.get(at..at + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let truncated = || {
        format!(
            "the file ({len} bytes) is truncated: its index is missing (recording cut off, or an incomplete copy): copy the recording again, or record again"
        )
    };
    let m = BAG_MAGIC.len();
    let header_len = u32_at(m).ok_or_else(truncated)? as usize;
    let fields = head.get(m + 4..m + 4 + header_len).ok_or_else(truncated)?;
    let data_len = u32_at(m + 4 + header_len).ok_or_else(truncated)? as u64;
    let start = (m + 8 + header_len) as u64 + data_len;
    let mut index_pos = None;
    let mut rest = fields;
    while rest.len() >= 4 {
        let n = u32::from_le_bytes([rest[0], rest[1], rest[2], rest[3]]) as usize;
        let Some(field) = rest.get(4..4 + n) else {
            break;
        };
        if let Some(v) = field.strip_prefix(b"index_pos=") {
            if v.len() == 8 {
                let mut b = [0u8; 8];
                b.copy_from_slice(v);
                index_pos = Some(u64::from_le_bytes(b));
            }
        }
        rest = &rest[4 + n..];
    }
    let index_pos = index_pos.ok_or_else(|| {
        "bag header has no index position: the file is corrupt: copy the recording again"
            .to_string()
    })?;
    if index_pos < start || index_pos > len || start > len {
        return Err(if index_pos == 0 {
            format!("the recording was never closed (no index; {len} bytes): stop recordings in the Viewer before copying, or record again")
        } else {
            format!(
                "the file ends at byte {len} but its index starts at byte {index_pos}: the bag is truncated (recording cut off, or an incomplete copy): copy the recording again, or record again"
            )
        });
    }
    Ok(())
}

/// The role of a topic of the recording, when it is one we read; the stream prefixes
/// are those of the first colour and depth image topics.
fn role_of(topic: &str, color: &str, depth: &str) -> Option<Role> {
    let tail = |prefix: &str| topic.strip_prefix(prefix).and_then(|t| t.strip_prefix('/'));
    let sensor = |prefix: &str| prefix.rsplit_once('/').map(|(s, _)| s.to_string());
    if let Some(t) = tail(color) {
        return match t {
            IMAGE_DATA => Some(Role::ColorImage),
            CAMERA_INFO => Some(Role::ColorInfo),
            _ => t
                .strip_prefix("tf/")
                .and_then(|g| g.parse().ok())
                .map(Role::ColorTf),
        };
    }
    if let Some(t) = tail(depth) {
        return match t {
            IMAGE_DATA => Some(Role::DepthImage),
            CAMERA_INFO => Some(Role::DepthInfo),
            _ => t
                .strip_prefix("tf/")
                .and_then(|g| g.parse().ok())
                .map(Role::DepthTf),
        };
    }
    let depth_sensor = sensor(depth)?;
    (tail(&depth_sensor) == Some(DEPTH_UNITS)).then_some(Role::DepthUnits)
}

/// The ROS type a role's messages must have.
fn expected_type(role: Role) -> &'static str {
    match role {
        Role::ColorImage | Role::DepthImage => "sensor_msgs/Image",
        Role::ColorInfo | Role::DepthInfo => "sensor_msgs/CameraInfo",
        Role::ColorTf(_) | Role::DepthTf(_) => "geometry_msgs/Transform",
        Role::DepthUnits => "std_msgs/Float32",
    }
}

/// Calls `f(conn, nth, data)` for each message record of the chunk at `pos`.
fn visit_chunk(
    bag: &RosBag,
    pos: u64,
    mut f: impl FnMut(u32, u32, &[u8]) -> Result<(), String>,
) -> Result<(), String> {
    let bad = |e: String| {
        let e = if e.contains("out of bounds") {
            "cut short".to_string()
        } else {
            e
        };
        format!(
            "truncated or corrupt recording: the chunk at byte {pos} cannot be read ({e}): copy the recording again, or record again"
        )
    };
    let mut records = bag.chunk_records();
    records.seek(pos).map_err(|e| bad(e.to_string()))?;
    let chunk = match records.next() {
        Some(Ok(ChunkRecord::Chunk(c))) => c,
        Some(Ok(_)) => return Err(bad("no chunk record there".into())),
        Some(Err(e)) => return Err(bad(e.to_string())),
        None => return Err(bad("past the chunk section".into())),
    };
    let mut nth = 0u32;
    for m in chunk.messages() {
        match m.map_err(|e| bad(e.to_string()))? {
            MessageRecord::MessageData(d) => {
                f(d.conn_id, nth, d.data)?;
                nth += 1;
            }
            MessageRecord::Connection(_) => {}
        }
    }
    Ok(())
}

/// The f64 of an f32's shortest decimal form: a Depth Units of 0.0001 stored as f32
/// reads 0.0001, not 0.000099999997 (an error of 2.5e-8 in every length otherwise).
fn f64_from_f32_decimal(v: f32) -> f64 {
    v.to_string().parse().unwrap_or(v as f64)
}

/// A camera from its `CameraInfo`: pinhole K, Brown distortion (refused: other models
/// with non-zero coefficients).
fn camera_from_info(info: &CameraInfoMsg, what: &str) -> Result<StreamCamera, String> {
    let k = info.k;
    let (fx, fy, cx, cy) = (k[0], k[4], k[2], k[5]);
    if info.width == 0
        || info.height == 0
        || !(fx.is_finite() && fy.is_finite() && fx > 0.0 && fy > 0.0)
        || !(cx.is_finite() && cy.is_finite())
    {
        return Err(format!(
            "{what} camera_info has no usable intrinsics ({}x{}, K = {k:?}): record again with the SDK's calibration",
            info.width, info.height
        ));
    }
    let mut brown = [0.0; 5];
    if info.d.iter().any(|c| *c != 0.0) {
        let model = info.distortion_model.to_ascii_lowercase();
        let is_brown = model == "plumb_bob" || model == "brown conrady";
        if !is_brown || info.d.len() > 5 || !info.d.iter().all(|c| c.is_finite()) {
            return Err(format!(
                "{what} distortion model `{}` with coefficients {:?} is not supported (Brown / plumb_bob k1 k2 p1 p2 k3 is): export the frames as PNG (color/, depth/ aligned in the Viewer) instead",
                info.distortion_model, info.d
            ));
        }
        brown[..info.d.len()].copy_from_slice(&info.d);
    }
    Ok(StreamCamera {
        width: info.width,
        height: info.height,
        fx,
        fy,
        cx,
        cy,
        brown,
    })
}

impl BagRecording {
    /// Opens `path`: checks it, reads its index, cameras, extrinsics and depth unit and
    /// lists its colour frames with their depth frames (no pixels decoded yet).
    pub fn open(path: &Path) -> Result<Self, RgbdError> {
        let fail = |why: String| RgbdError::Layout {
            path: path.to_path_buf(),
            why,
        };
        check_header(path).map_err(fail)?;
        let bag = RosBag::new(path).map_err(|e| fail(format!("not a readable bag ({e})")))?;
        // The index section: connections and chunk positions.
        let mut topics: BTreeMap<u32, (String, String)> = BTreeMap::new();
        let mut chunks: Vec<u64> = Vec::new();
        for r in bag.index_records() {
            // rosbag's own text ("out of bounds") says nothing to a user: a bag whose
            // index cannot be read was cut short or joined to another file.
            match r.map_err(|_| {
                fail(
                    "truncated or corrupt recording: its index cannot be read (an incomplete copy, or files joined): copy the recording again, or record again"
                        .into(),
                )
            })? {
                IndexRecord::Connection(c) => {
                    topics.insert(c.id, (c.topic.to_string(), c.tp.to_string()));
                }
                IndexRecord::ChunkInfo(c) => chunks.push(c.chunk_pos),
                IndexRecord::IndexData(_) => {}
            }
        }
        chunks.sort_unstable();
        chunks.dedup();
        let name = file_name(path);
        let stream_prefix = |stream: &str| -> Option<String> {
            let tail = format!("/{stream}/{IMAGE_DATA}");
            topics
                .values()
                .filter_map(|(t, _)| t.strip_suffix(&tail).map(|p| format!("{p}/{stream}")))
                .min()
        };
        let color = stream_prefix(COLOR_STREAM).ok_or_else(|| {
            fail(format!(
                "no colour stream (/device_0/sensor_1/{COLOR_STREAM}/{IMAGE_DATA}): record with the colour stream on"
            ))
        })?;
        let depth = stream_prefix(DEPTH_STREAM).ok_or_else(|| {
            fail(format!(
                "no depth stream (/device_0/sensor_0/{DEPTH_STREAM}/{IMAGE_DATA}): record with the depth stream on (RealSense Viewer: Stereo Module), or give color/ + depth/ PNG frames"
            ))
        })?;
        let mut roles: BTreeMap<u32, (Role, String)> = BTreeMap::new();
        for (id, (topic, tp)) in &topics {
            if let Some(role) = role_of(topic, &color, &depth) {
                if tp != expected_type(role) {
                    return Err(fail(format!(
                        "{topic} carries {tp}, not {}: not a RealSense recording this reader knows",
                        expected_type(role)
                    )));
                }
                roles.insert(*id, (role, topic.clone()));
            }
        }
        // Every chunk once: small messages decoded, image headers read.
        let (mut colors, mut depths) = (Vec::new(), Vec::new());
        let (mut color_info, mut depth_info) = (None, None);
        let (mut color_tf, mut depth_tf) = (None, None);
        let mut depth_unit = None;
        for &pos in &chunks {
            visit_chunk(&bag, pos, |conn, nth, data| {
                let Some((role, topic)) = roles.get(&conn) else {
                    return Ok(());
                };
                let bad = |e: super::rosmsg::MsgError| format!("{topic}: undecodable message ({e}): the file is corrupt: copy the recording again");
                match *role {
                    Role::ColorImage | Role::DepthImage => {
                        let h = image_header_from_bytes(data).map_err(bad)?;
                        let r = MessageRef {
                            chunk_pos: pos,
                            nth,
                            stamp_ns: h.stamp_ns,
                        };
                        if *role == Role::ColorImage {
                            colors.push(r);
                        } else {
                            depths.push(r);
                        }
                    }
                    Role::ColorInfo if color_info.is_none() => {
                        color_info = Some(camera_info_from_bytes(data).map_err(bad)?)
                    }
                    Role::DepthInfo if depth_info.is_none() => {
                        depth_info = Some(camera_info_from_bytes(data).map_err(bad)?)
                    }
                    Role::ColorTf(g) if color_tf.is_none() => {
                        color_tf = Some((g, transform_from_bytes(data).map_err(bad)?))
                    }
                    Role::DepthTf(g) if depth_tf.is_none() => {
                        depth_tf = Some((g, transform_from_bytes(data).map_err(bad)?))
                    }
                    Role::DepthUnits => {
                        depth_unit = Some(f64_from_f32_decimal(float32_from_bytes(data).map_err(bad)?))
                    }
                    _ => {}
                }
                Ok(())
            })
            .map_err(fail)?;
        }
        if colors.is_empty() {
            return Err(fail(format!(
                "{color}/{IMAGE_DATA} holds no frames: record again"
            )));
        }
        if depths.is_empty() {
            return Err(fail(format!(
                "{depth}/{IMAGE_DATA} holds no frames: record with the depth stream on, or give color/ + depth/ PNG frames"
            )));
        }
        let info = |i: Option<CameraInfoMsg>, topic: &str| {
            i.ok_or_else(|| {
                fail(format!(
                    "no {topic}/{CAMERA_INFO}: the recording lacks the camera's intrinsics: record with the RealSense Viewer or rs-record"
                ))
            })
        };
        let color_camera = camera_from_info(&info(color_info, &color)?, "colour").map_err(fail)?;
        let depth_camera = camera_from_info(&info(depth_info, &depth)?, "depth").map_err(fail)?;
        let mut notes = Vec::new();
        let depth_unit_m = match depth_unit {
            Some(u) if u.is_finite() && u > 0.0 => u,
            Some(u) => {
                return Err(fail(format!(
                    "depth unit {u} m is not positive: the recording's Depth Units option is broken"
                )))
            }
            None => {
                notes.push(format!(
                    "{name}: no Depth Units option recorded: taken as {DEFAULT_DEPTH_UNIT_M} m"
                ));
                DEFAULT_DEPTH_UNIT_M
            }
        };
        let depth_to_color = match (color_tf, depth_tf) {
            (Some((gc, tc)), Some((gd, td))) if gc == gd => tc.after(&td.inverse()),
            (Some((gc, _)), Some((gd, _))) => {
                return Err(fail(format!(
                    "colour and depth extrinsics are in different groups (tf/{gc}, tf/{gd}): no depth-to-colour transform"
                )))
            }
            (Some((_, tc)), None) => tc,
            (None, Some((_, td))) => td.inverse(),
            (None, None) if color_camera == depth_camera => {
                notes.push(format!(
                    "{name}: no extrinsics recorded and the depth camera equals the colour camera: depth taken as aligned"
                ));
                RigidTransform::identity()
            }
            (None, None) => {
                return Err(fail(format!(
                    "no extrinsics ({color}/tf/0, {depth}/tf/0): depth cannot be aligned to colour: record with the RealSense Viewer or rs-record"
                )))
            }
        };
        let (frames, fps, timing) = match_frames(colors, depths);
        let intrinsics = RgbdIntrinsics {
            width: color_camera.width,
            height: color_camera.height,
            fx: color_camera.fx,
            fy: color_camera.fy,
            cx: color_camera.cx,
            cy: color_camera.cy,
            depth_scale_m: depth_unit_m,
            fps,
            distortion: if color_camera.brown.iter().any(|c| *c != 0.0) {
                color_camera.brown.to_vec()
            } else {
                vec![]
            },
        };
        Ok(Self {
            aligner: DepthAligner::new(&depth_camera, &color_camera, &depth_to_color),
            path: path.to_path_buf(),
            bag,
            intrinsics,
            color_camera,
            depth_camera,
            depth_to_color,
            depth_unit_m,
            frames,
            timing,
            notes,
            cache: VecDeque::new(),
        })
    }

    /// The recording's file name.
    pub fn name(&self) -> String {
        file_name(&self.path)
    }

    /// The message bytes at `r`, from the chunk cache or its chunk.
    fn message(&mut self, r: &MessageRef) -> Result<&[u8], String> {
        let slot = match self.cache.iter().position(|(p, _)| *p == r.chunk_pos) {
            Some(i) => i,
            None => {
                let mut msgs = Vec::new();
                visit_chunk(&self.bag, r.chunk_pos, |_, _, d| {
                    msgs.push(d.to_vec());
                    Ok(())
                })?;
                if self.cache.len() >= CHUNKS_CACHED {
                    self.cache.pop_front();
                }
                self.cache.push_back((r.chunk_pos, msgs));
                self.cache.len() - 1
            }
        };
        self.cache[slot]
            .1
            .get(r.nth as usize)
            .map(Vec::as_slice)
            .ok_or_else(|| {
                format!(
                    "message {} of the chunk at byte {} is missing",
                    r.nth, r.chunk_pos
                )
            })
    }

    /// Frame `k`'s colour pixels and its depth aligned to colour (in depth units), or
    /// what is wrong with it.
    pub fn read_frame(&mut self, k: usize) -> Result<(image::RgbImage, DepthImage), String> {
        let name = self.name();
        let f = self
            .frames
            .get(k)
            .cloned()
            .ok_or_else(|| format!("{name}: no frame {k}"))?;
        let depth_ref = f.depth.ok_or_else(|| {
            format!(
                "{name}: colour frame {} at {:.3} s has no depth frame within {:.0} ms (nearest {:.0} ms away): depth frames were dropped",
                f.index,
                f.time_s,
                1000.0 * MAX_DEPTH_GAP_FRAMES / self.intrinsics.fps,
                1000.0 * f.depth_gap_s
            )
        })?;
        let what = |stream: &str, e: String| {
            format!(
                "{name}: {stream} frame {} at {:.3} s: {e}",
                f.index, f.time_s
            )
        };
        let color_cam = self.color_camera.clone();
        let rgb = {
            let bytes = self.message(&f.color).map_err(|e| what("colour", e))?;
            let m = image_from_bytes(bytes).map_err(|e| what("colour", e.to_string()))?;
            if (m.width, m.height) != (color_cam.width, color_cam.height) {
                return Err(what(
                    "colour",
                    format!(
                        "{}x{} differs from its camera_info's {}x{}",
                        m.width, m.height, color_cam.width, color_cam.height
                    ),
                ));
            }
            rgb_from_image(&m).map_err(|e| what("colour", e))?
        };
        let depth_cam = self.depth_camera.clone();
        let raw = {
            let bytes = self.message(&depth_ref).map_err(|e| what("depth", e))?;
            let m = image_from_bytes(bytes).map_err(|e| what("depth", e.to_string()))?;
            if (m.width, m.height) != (depth_cam.width, depth_cam.height) {
                return Err(what(
                    "depth",
                    format!(
                        "{}x{} differs from its camera_info's {}x{}",
                        m.width, m.height, depth_cam.width, depth_cam.height
                    ),
                ));
            }
            depth_from_image(&m).map_err(|e| what("depth", e))?
        };
        let aligned = self.aligner.align(&raw, self.depth_unit_m);
        if aligned.as_raw().iter().all(|&d| d == 0) {
            return Err(what(
                "depth",
                "no valid depth pixel lands in the colour image (all zero): check the depth stream"
                    .into(),
            ));
        }
        Ok((rgb, aligned))
    }
}

/// Colour frames in stamp order, each with the depth frame of the nearest stamp; the
/// colour rate (1 / median stamp step) and the timing note.
fn match_frames(
    mut colors: Vec<MessageRef>,
    mut depths: Vec<MessageRef>,
) -> (Vec<BagFrame>, f64, String) {
    colors.sort_by_key(|r| r.stamp_ns);
    depths.sort_by_key(|r| r.stamp_ns);
    let t0 = colors[0].stamp_ns;
    let steps: Vec<f64> = colors
        .windows(2)
        .map(|w| (w[1].stamp_ns - w[0].stamp_ns) as f64 * 1e-9)
        .filter(|s| *s > 0.0)
        .collect();
    let period = if steps.is_empty() {
        1.0 / 30.0
    } else {
        crate::measure::stats::median(&steps)
    };
    let frames = colors
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let at = depths.partition_point(|d| d.stamp_ns < c.stamp_ns);
            let nearest = [at.checked_sub(1), Some(at)]
                .into_iter()
                .flatten()
                .filter_map(|j| depths.get(j))
                .min_by_key(|d| d.stamp_ns.abs_diff(c.stamp_ns));
            let gap = nearest
                .map(|d| d.stamp_ns.abs_diff(c.stamp_ns) as f64 * 1e-9)
                .unwrap_or(f64::INFINITY);
            BagFrame {
                index: i as u64,
                time_s: (c.stamp_ns - t0) as f64 * 1e-9,
                color: *c,
                depth: nearest
                    .filter(|_| gap <= MAX_DEPTH_GAP_FRAMES * period * 1.000_001)
                    .copied(),
                depth_gap_s: gap,
            }
        })
        .collect();
    (
        frames,
        1.0 / period,
        format!(
            "times from the colour frames' header stamps (time 0 = the first colour frame, {:.1} fps), depth frames matched by nearest stamp",
            1.0 / period
        ),
    )
}

/// RGB pixels of an `rgb8`, `bgr8`, `rgba8` or `bgra8` image (rows of `step` bytes).
pub fn rgb_from_image(m: &super::rosmsg::ImageMsg<'_>) -> Result<image::RgbImage, String> {
    let (order, bpp): ([usize; 3], usize) = match m.encoding.as_str() {
        "rgb8" => ([0, 1, 2], 3),
        "bgr8" => ([2, 1, 0], 3),
        "rgba8" => ([0, 1, 2], 4),
        "bgra8" => ([2, 1, 0], 4),
        other => {
            return Err(format!(
            "encoding `{other}` is not read (rgb8, bgr8, rgba8, bgra8 are): record colour as RGB8"
        ))
        }
    };
    let (w, h, step) = (m.width as usize, m.height as usize, m.step as usize);
    if step < w * bpp {
        return Err(format!(
            "row step {step} is shorter than {w} pixels of {bpp} bytes"
        ));
    }
    let mut out = Vec::with_capacity(w * h * 3);
    for row in m.data.chunks(step).take(h) {
        for px in row[..w * bpp].chunks_exact(bpp) {
            out.extend(order.iter().map(|&c| px[c]));
        }
    }
    image::RgbImage::from_raw(m.width, m.height, out)
        .ok_or_else(|| "pixel data shorter than the image".to_string())
}

/// Depth units of a `16UC1` / `mono16` image, row-major (rows of `step` bytes).
pub fn depth_from_image(m: &super::rosmsg::ImageMsg<'_>) -> Result<Vec<u16>, String> {
    if m.encoding != "16UC1" && m.encoding != "mono16" {
        return Err(format!(
            "encoding `{}` is not read (16UC1 / mono16 are): record depth as Z16",
            m.encoding
        ));
    }
    let (w, h, step) = (m.width as usize, m.height as usize, m.step as usize);
    if step < 2 * w {
        return Err(format!("row step {step} is shorter than {w} 16-bit pixels"));
    }
    let mut out = Vec::with_capacity(w * h);
    for row in m.data.chunks(step).take(h) {
        out.extend(row[..2 * w].chunks_exact(2).map(|b| {
            if m.is_bigendian {
                u16::from_be_bytes([b[0], b[1]])
            } else {
                u16::from_le_bytes([b[0], b[1]])
            }
        }));
    }
    if out.len() != w * h {
        return Err("pixel data shorter than the image".into());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::rosmsg::tests::Ser;
    use super::*;

    #[test]
    fn topics_get_their_roles_from_the_stream_prefixes() {
        let (c, d) = ("/device_0/sensor_1/Color_0", "/device_0/sensor_0/Depth_0");
        let role = |t: &str| role_of(t, c, d);
        assert_eq!(
            role("/device_0/sensor_1/Color_0/image/data"),
            Some(Role::ColorImage)
        );
        assert_eq!(
            role("/device_0/sensor_0/Depth_0/image/data"),
            Some(Role::DepthImage)
        );
        assert_eq!(
            role("/device_0/sensor_1/Color_0/info/camera_info"),
            Some(Role::ColorInfo)
        );
        assert_eq!(
            role("/device_0/sensor_0/Depth_0/tf/0"),
            Some(Role::DepthTf(0))
        );
        assert_eq!(
            role("/device_0/sensor_1/Color_0/tf/0"),
            Some(Role::ColorTf(0))
        );
        assert_eq!(
            role("/device_0/sensor_0/option/Depth Units/value"),
            Some(Role::DepthUnits)
        );
        assert_eq!(role("/device_0/sensor_1/option/Exposure/value"), None);
        assert_eq!(role("/device_0/sensor_1/Color_0/image/metadata"), None);
        assert_eq!(role("/device_0/sensor_1/option/Depth Units/value"), None);
    }

    fn image(enc: &str, w: u32, h: u32, step: u32, big: bool, px: &[u8]) -> Vec<u8> {
        Ser::default()
            .header(0, 0, 0, "")
            .u32(h)
            .u32(w)
            .bytes(enc.as_bytes())
            .u8(big as u8)
            .u32(step)
            .bytes(px)
            .0
    }

    #[test]
    fn colour_encodings_give_rgb_and_row_padding_is_skipped() {
        // 2x1 pixels, rows padded to 8 (bgr8) / 10 (bgra8) bytes.
        let bgr = image("bgr8", 2, 1, 8, false, &[3, 2, 1, 6, 5, 4, 0, 0]);
        let m = image_from_bytes(&bgr).unwrap();
        assert_eq!(rgb_from_image(&m).unwrap().as_raw(), &[1, 2, 3, 4, 5, 6]);
        let bgra = image("bgra8", 2, 1, 10, false, &[3, 2, 1, 9, 6, 5, 4, 9, 0, 0]);
        let m = image_from_bytes(&bgra).unwrap();
        assert_eq!(rgb_from_image(&m).unwrap().as_raw(), &[1, 2, 3, 4, 5, 6]);
        let rgba = image("rgba8", 1, 1, 4, false, &[1, 2, 3, 255]);
        let m = image_from_bytes(&rgba).unwrap();
        assert_eq!(rgb_from_image(&m).unwrap().as_raw(), &[1, 2, 3]);
        let yuv = image("yuv422", 1, 1, 2, false, &[1, 2]);
        let e = rgb_from_image(&image_from_bytes(&yuv).unwrap()).unwrap_err();
        assert!(e.contains("yuv422") && e.contains("RGB8"), "{e}");
    }

    #[test]
    fn depth_units_keep_their_decimal_value() {
        assert_eq!(f64_from_f32_decimal(0.0001), 0.0001);
        assert_eq!(f64_from_f32_decimal(0.001), 0.001);
        assert_eq!(f64_from_f32_decimal(0.000_125), 0.000_125);
    }

    #[test]
    fn depth_reads_both_byte_orders() {
        let le = image("16UC1", 2, 1, 4, false, &[0x34, 0x12, 0x01, 0x00]);
        assert_eq!(
            depth_from_image(&image_from_bytes(&le).unwrap()).unwrap(),
            vec![0x1234, 1]
        );
        let be = image("mono16", 2, 1, 4, true, &[0x12, 0x34, 0x00, 0x01]);
        assert_eq!(
            depth_from_image(&image_from_bytes(&be).unwrap()).unwrap(),
            vec![0x1234, 1]
        );
        let f32 = image("32FC1", 1, 1, 4, false, &[0, 0, 0, 0]);
        assert!(depth_from_image(&image_from_bytes(&f32).unwrap()).is_err());
    }

    #[test]
    fn frames_are_timed_from_the_first_colour_stamp_and_take_the_nearest_depth() {
        let r = |chunk_pos: u64, stamp_ms: u64| MessageRef {
            chunk_pos,
            nth: 0,
            stamp_ns: stamp_ms * 1_000_000,
        };
        // Colour at 1000, 1033, 1066, 1100 ms (out of file order); depth at 1010, 1045
        // and 1300: the last colour frame's nearest depth is 200 ms away: none.
        let colors = vec![r(2, 1066), r(0, 1000), r(1, 1033), r(3, 1100)];
        let depths = vec![r(10, 1045), r(11, 1010), r(12, 1300)];
        let (frames, fps, _) = match_frames(colors, depths);
        assert!((fps - 1000.0 / 33.0).abs() < 1e-9, "{fps}");
        let t: Vec<f64> = frames.iter().map(|f| f.time_s).collect();
        assert_eq!(t, vec![0.0, 0.033, 0.066, 0.1]);
        let d: Vec<Option<u64>> = frames
            .iter()
            .map(|f| f.depth.map(|d| d.chunk_pos))
            .collect();
        assert_eq!(d, vec![Some(11), Some(10), Some(10), None]);
        assert!((frames[3].depth_gap_s - 0.055).abs() < 1e-9);
    }

    #[test]
    fn a_file_that_is_no_bag_or_has_no_index_is_refused_with_what_to_do() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.bag");
        std::fs::write(&p, b"hello").unwrap();
        assert!(check_header(&p).unwrap_err().contains("not a ROS1 bag"));
        // A header record whose index_pos points past the end.
        let field = |name: &str, v: &[u8]| {
            let mut f = (name.len() as u32 + 1 + v.len() as u32)
                .to_le_bytes()
                .to_vec();
            f.extend_from_slice(name.as_bytes());
            f.push(b'=');
            f.extend_from_slice(v);
            f
        };
        let mut fields = field("op", &[3]);
        fields.extend(field("index_pos", &100_000u64.to_le_bytes()));
        let mut bag = BAG_MAGIC.to_vec();
        bag.extend((fields.len() as u32).to_le_bytes());
        bag.extend(&fields);
        bag.extend(8u32.to_le_bytes());
        bag.extend([b' '; 8]);
        std::fs::write(&p, &bag).unwrap();
        let e = check_header(&p).unwrap_err();
        assert!(
            e.contains("truncated") && e.contains("copy the recording again"),
            "{e}"
        );
        let e = BagRecording::open(&p).err().unwrap().to_string();
        assert!(e.starts_with(&p.display().to_string()), "{e}");
    }

    #[test]
    fn a_bag_cut_slightly_short_or_joined_to_itself_is_a_truncated_or_corrupt_recording() {
        let bag = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/bags/baseline/recording.bag"
        ))
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.bag");
        for (what, bytes) in [
            ("cut 1% short", bag[..bag.len() * 99 / 100].to_vec()),
            (
                "joined to itself",
                [bag.as_slice(), bag.as_slice()].concat(),
            ),
        ] {
            std::fs::write(&p, &bytes).unwrap();
            let e = match BagRecording::open(&p) {
                Ok(_) => panic!("{what}: opened"),
                Err(e) => e.to_string(),
            };
            assert!(
                e.contains("truncated") && e.contains("copy the recording again"),
                "{what}: {e}"
            );
            assert!(
                !e.contains("out of bounds") && !e.contains("rosbag"),
                "{what}: {e}"
            );
        }
    }
}
